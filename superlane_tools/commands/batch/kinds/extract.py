"""The ``extract`` job kind: ``slt extract`` on one recording (or one window of it)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from superlane_tools.commands.batch.jobs import JobKind, JobResult
from superlane_tools.errors import ConfigError, UsageError

_EXTRACT_KEYS = frozenset(
    {"topics", "streams", "frame_format", "every", "dbc_paths", "start_s", "end_s"}
)


def _extract_config(config: Mapping[str, Any]) -> Any:
    from superlane_tools.commands.extract import ExtractConfig

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

    from superlane_tools.commands.extract import extract

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


EXTRACT = JobKind(
    "extract",
    _extract_check,
    _extract_identities,
    _extract_load,
    _extract_run,
    True,
    preload=("superlane_tools.commands.extract.run", "cv2", "mcap_ros2.decoder"),
)
