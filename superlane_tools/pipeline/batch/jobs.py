"""Job kinds: what one batch job does to one recording (``reprocess`` or ``extract``).

A kind is four plain functions, looked up by name in each worker (so only the name travels):
``check`` validates the configuration in the driver, ``identities`` names the model and data
files (with their SHA-256) that enter the idempotency key, ``load`` runs once per worker
(ONNX sessions, DBCs) and ``run`` processes one recording into a folder.
"""

from __future__ import annotations

import importlib.util
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools.errors import ConfigError, UsageError


class JobResult(NamedTuple):
    """What a job kind's ``run`` produced in its output folder.

    Attributes:
        status: ``ok``, or ``partial`` when input data was lost or skipped.
        note: One line on what was lost (``partial``), else ``""``.
        outputs: Files written.
        frames: Frames processed.
        timings: Stage name -> seconds.
    """

    status: str
    note: str
    outputs: int
    frames: int
    timings: Mapping[str, float]


class JobKind(NamedTuple):
    """The functions of one job kind (see the module docstring)."""

    name: str
    check: Callable[[Mapping[str, Any]], None]
    identities: Callable[[Mapping[str, Any]], dict[str, str]]
    load: Callable[[Mapping[str, Any]], Any]
    run: Callable[[Path, Path, Mapping[str, Any], Any], JobResult]
    split_sequences: bool = True
    """True: one job per manifest sequence (config keys ``start_s``/``end_s``). False: one job
    per recording, its sequences passed as ``segments`` and its ``category`` in the config."""


# --- extract --------------------------------------------------------------------------------

_EXTRACT_KEYS = frozenset(
    {"topics", "streams", "frame_format", "every", "dbc_paths", "start_s", "end_s"}
)


def _extract_config(config: Mapping[str, Any]) -> Any:
    from superlane_tools.pipeline.extract import ExtractConfig

    unknown = set(config) - _EXTRACT_KEYS
    if unknown:
        raise ConfigError(
            f"unknown extract config keys {sorted(unknown)}; expected {sorted(_EXTRACT_KEYS)}"
        )
    try:
        streams = {k: _names(v) for k, v in dict(config.get("streams") or {}).items()}
        start, end = config.get("start_s"), config.get("end_s")
        return ExtractConfig(
            topics=_names(config.get("topics") or ()),
            streams=streams,
            start_s=None if start is None else float(start),
            end_s=None if end is None else float(end),
            dbc_paths=tuple(Path(str(p)) for p in _names(config.get("dbc_paths") or ())),
            frame_format=str(config.get("frame_format", "jpg")),
            every=int(config.get("every", 1)),
        )
    except (TypeError, ValueError) as err:  # wrong value types in the YAML
        raise ConfigError(f"bad extract config value: {err}") from err


def _names(value: Any) -> tuple[str, ...]:
    """A list of names from a config value (one string is a list of one)."""
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list | tuple) or not all(isinstance(v, str) for v in items):
        raise TypeError(f"expected a list of names, got {value!r}")
    return tuple(items)


def _extract_check(config: Mapping[str, Any]) -> None:
    _extract_config(config)


def _extract_identities(config: Mapping[str, Any]) -> dict[str, str]:
    from superlane_tools.reporting import file_sha256

    out: dict[str, str] = {}
    for item in config.get("dbc_paths") or ():
        path = Path(item)
        try:
            out[f"dbc:{path.name}"] = file_sha256(path)
        except OSError as err:
            raise UsageError(f"cannot read DBC {path}: {err.strerror}") from err
    return out


def _extract_load(config: Mapping[str, Any]) -> Any:
    return _extract_config(config)


def _extract_run(
    recording: Path, out_dir: Path, config: Mapping[str, Any], loaded: Any
) -> JobResult:
    from dataclasses import replace

    from superlane_tools.pipeline.extract import extract

    settings = replace(loaded, start_s=config.get("start_s"), end_s=config.get("end_s"))
    t0 = time.perf_counter()
    result = extract(recording, out_dir, settings, command="slt batch --job extract")
    elapsed = time.perf_counter() - t0
    note = "; ".join(f"{s.what}: {s.detail}" for s in result.skipped)
    return JobResult(
        status="partial" if result.skipped else "ok",
        note=note,
        outputs=len(result.outputs),
        frames=int(result.counts.get("frames", 0)),
        timings={"extract_s": elapsed},
    )


EXTRACT = JobKind("extract", _extract_check, _extract_identities, _extract_load, _extract_run, True)


# --- registry -------------------------------------------------------------------------------


def reprocess_available() -> bool:
    """Return True when the ``reprocess`` pipeline is part of this installation."""
    try:
        spec = importlib.util.find_spec("superlane_tools.pipeline.reprocess")
    except ImportError:
        return False
    # A folder without __init__.py (work in progress) is a namespace package: origin None.
    return spec is not None and spec.origin is not None


def default_kind() -> str:
    """Return the default job kind: ``reprocess`` when available, else ``extract``."""
    return "reprocess" if reprocess_available() else "extract"


def job_kind(name: str) -> JobKind:
    """Return the job kind called ``name``.

    Raises:
        UsageError: If the kind is unknown or not available in this installation.
    """
    if name == "extract":
        return EXTRACT
    if name == "reprocess":
        if not reprocess_available():
            raise UsageError("job kind 'reprocess' is not available in this installation")
        from superlane_tools.pipeline.batch import _reprocess_job

        return _reprocess_job.REPROCESS
    raise UsageError(f"unknown job kind {name!r}: use 'reprocess' or 'extract'")


def load_config_file(path: str | Path) -> dict[str, Any]:
    """Read a job configuration mapping from a ``.toml``, ``.yaml``/``.yml`` or ``.json`` file.

    Raises:
        ConfigError: If the file cannot be read or is not a mapping.
    """
    import json

    src = Path(path)
    try:
        text = src.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"cannot read config {src}: {err}") from err
    suffix = src.suffix.lower()
    try:
        if suffix == ".toml":
            import tomllib

            data: Any = tomllib.loads(text)
        elif suffix == ".json":
            data = json.loads(text)
        else:
            import yaml

            data = yaml.safe_load(text) or {}
    except Exception as err:  # TOMLDecodeError, JSONDecodeError, YAMLError
        raise ConfigError(f"{src}: cannot parse config: {err}") from err
    if not isinstance(data, dict):
        raise ConfigError(f"{src}: the config must be a mapping")
    return data
