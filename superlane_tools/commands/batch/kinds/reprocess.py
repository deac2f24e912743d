"""The ``reprocess`` job kind: ``slt reprocess`` on one recording, as a batch job.

The batch configuration is a ``slt reprocess`` configuration mapping (TOML/YAML sections) plus
two batch keys filled from the manifest: ``category`` (the KPI category of the recording's
sequences) and ``segments`` (``[{start_s, stop_s, category}, ...]`` sequence boundaries, seconds
after the first frame), passed to the run as its KPI sequences.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from superlane_tools.commands.batch.jobs import JobKind, JobResult
from superlane_tools.errors import ConfigError

BATCH_KEYS = frozenset({"category", "segments"})
"""Keys the batch adds to a reprocess configuration (from the manifest)."""


def _config(config: Mapping[str, Any]) -> Any:
    from superlane_tools.drive.config import config_from_mapping

    return config_from_mapping({k: v for k, v in config.items() if k not in BATCH_KEYS})


def _check(config: Mapping[str, Any]) -> None:
    _config(config)


def _file_identity(label: str, name_or_path: str, out: dict[str, str]) -> None:
    from superlane_tools.reporting import file_sha256
    from superlane_tools.scene.onnx_backend import resolve_model

    try:
        path, _ = resolve_model(name_or_path)
    except Exception:  # not shipped and not a file: reprocess reports it or falls back
        return
    out[f"{label}:{path.name}"] = file_sha256(path)


def _identities(config: Mapping[str, Any]) -> dict[str, str]:
    """SHA-256 of the models and DBCs a run with this configuration would use."""
    from superlane_tools.can import shipped_dbcs
    from superlane_tools.models import list_models
    from superlane_tools.reporting import file_sha256
    from superlane_tools.scene.onnx_backend import (
        DEFAULT_CORRIDOR_MODEL,
        DEFAULT_SEGMENTATION_MODEL,
    )

    cfg = _config(config)
    out: dict[str, str] = {}
    shipped = set(list_models())
    seg = cfg.segmentation.model or (
        DEFAULT_SEGMENTATION_MODEL if DEFAULT_SEGMENTATION_MODEL in shipped else ""
    )
    if seg and cfg.segmentation.backend in {"auto", "onnx"}:
        _file_identity("segmentation", seg, out)
    corridor = cfg.corridor.model or (
        DEFAULT_CORRIDOR_MODEL if DEFAULT_CORRIDOR_MODEL in shipped else ""
    )
    if corridor:
        _file_identity("corridor", corridor, out)
    dbcs = [Path(p) for p in cfg.can.dbcs] or shipped_dbcs()
    for path in dbcs:
        try:
            out[f"dbc:{path.name}"] = file_sha256(path)
        except OSError as err:
            raise ConfigError(f"cannot read DBC {path}: {err.strerror}") from err
    return out


def _load(config: Mapping[str, Any]) -> Any:
    """Parse the configuration once per worker; image threads follow the worker's share."""
    from dataclasses import replace

    cfg = _config(config)
    if "workers" not in config:
        threads = int(os.environ.get("OMP_NUM_THREADS", "0") or 0)
        if threads >= 1:
            cfg = replace(cfg, workers=threads)
    return cfg


def _run(recording: Path, out_dir: Path, config: Mapping[str, Any], loaded: Any) -> JobResult:
    from dataclasses import replace

    from superlane_tools.commands.reprocess.run import reprocess
    from superlane_tools.corridor import TimeSegment

    cfg = loaded
    category = str(config.get("category") or "")
    given = config.get("segments") or []
    if category:
        cfg = replace(cfg, kpi=replace(cfg.kpi, category=category))
    segments = None
    if given:
        if not isinstance(given, list):
            raise ConfigError("segments must be a list of {start_s, stop_s, category}")
        segments = [
            TimeSegment(float(s["start_s"]), float(s["stop_s"]), str(s.get("category") or category))
            for s in given
        ]
    t0 = time.perf_counter()
    result = reprocess(
        recording, out_dir, cfg, command="slt batch --job reprocess", segments=segments
    )
    from superlane_tools.reporting.run_folder import write_run_manifest

    write_run_manifest(out_dir)  # last: marks the run folder complete for `slt tables`
    timings = {f"{k}_s": float(v) for k, v in result.timings.items() if k != "total"}
    timings["reprocess_s"] = time.perf_counter() - t0
    note = "; ".join(f"{s.what}: {s.detail}" for s in result.skipped)
    return JobResult(
        status="partial" if result.status == "partial" else "ok",
        note=note,
        outputs=len(result.outputs),
        frames=int(result.frames),
        timings=timings,
    )


REPROCESS = JobKind(
    "reprocess",
    _check,
    _identities,
    _load,
    _run,
    split_sequences=False,
    preload=("superlane_tools.commands.reprocess.run", "cv2", "onnxruntime", "matplotlib"),
)
