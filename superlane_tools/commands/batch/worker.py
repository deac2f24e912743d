"""The worker side of a batch: load models once, run one job, finalise its folder atomically.

Every engine calls :func:`init_worker` once per worker process and :func:`execute` per job. A
job builds its outputs in ``ROOT/.tmp/<id>.<host>.<pid>/``, writes the marker
``.slt_batch.json`` there last, then renames the folder to ``ROOT/<id>``; a folder without the
marker never appears under ``ROOT``, so a killed run leaves at most a stale temporary folder.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import socket
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from superlane_tools._version import __version__
from superlane_tools.commands.batch.engine import (
    TMP_DIR,
    Job,
    JobOutcome,
    JobStatus,
    error_line,
    failed_outcome,
    one_line,
)
from superlane_tools.commands.batch.kinds import job_kind

MARKER = ".slt_batch.json"
"""Marker file inside a finalised recording folder: key, status, timings (JSON)."""

ORPHAN_CHECK_S = 1.0
"""How often a local worker checks that its driver still lives, seconds."""

_LOADED: dict[str, Any] = {}
_WINDOW_KEYS = frozenset({"start_s", "end_s", "category", "segments"})
_HOST = socket.gethostname()


def _cache_key(kind: str, config: Mapping[str, Any]) -> str:
    return kind + "\0" + json.dumps(config, sort_keys=True, default=str)


def init_worker(
    kind: str, config: Mapping[str, Any], threads: int = 1, driver_pid: int | None = None
) -> None:
    """Prepare this worker process: cap library threads, load the kind's models once.

    Args:
        kind: Job kind name.
        config: The batch configuration (without per-recording windows).
        threads: Threads each native library (cv2, BLAS) may use in this worker.
        driver_pid: The batch driver's process; when given, this worker exits within
            :data:`ORPHAN_CHECK_S` once the driver is gone (a killed ``slt batch`` must not leave
            idle workers holding models in memory; their unfinished folders are then stale and
            removed by the next run).
    """
    if driver_pid is not None:
        threading.Thread(
            target=_exit_when_gone, args=(driver_pid,), name="slt-orphan-check", daemon=True
        ).start()
    with contextlib.suppress(ImportError):
        import cv2

        cv2.setNumThreads(max(1, threads))
    key = _cache_key(kind, config)
    if key not in _LOADED:
        _LOADED[key] = job_kind(kind).load(config)


def _exit_when_gone(pid: int) -> None:
    """Exit this process as soon as process ``pid`` no longer exists (checked every second)."""
    while True:
        time.sleep(ORPHAN_CHECK_S)
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            os._exit(1)
        except PermissionError:  # alive, owned by another user
            continue


def read_marker(folder: Path) -> dict[str, Any] | None:
    """Return the marker of a finalised recording folder, or None when absent or unreadable."""
    try:
        data = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def tmp_name(recording_id: str, host: str = _HOST, pid: int | None = None) -> str:
    """Name of a worker's temporary folder under ``ROOT/.tmp``: ``<id>.<host>.<pid>``."""
    return f"{recording_id}.{host}.{os.getpid() if pid is None else pid}"


def execute(job: Job, batch_config: Mapping[str, Any] | None = None) -> JobOutcome:
    """Run one job in this worker and finalise its output folder; never raises for the job.

    Args:
        job: The job.
        batch_config: Configuration the worker's models were loaded with (default: the job's
            config without its window keys).

    Returns:
        The outcome; ``failed`` with a one-line reason on any error.
    """
    pid = os.getpid()
    t0 = time.perf_counter()
    tmp = job.root / TMP_DIR / tmp_name(job.recording_id, _HOST, pid)
    try:
        kind = job_kind(job.kind)
        base = batch_config if batch_config is not None else _without_window(job.config)
        key = _cache_key(job.kind, base)
        if key not in _LOADED:
            _LOADED[key] = kind.load(base)
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)
        result = kind.run(job.recording, tmp, job.config, _LOADED[key])
        timings = {**result.timings, "total_s": time.perf_counter() - t0}
        marker = {
            "key": job.key,
            "status": result.status,
            "note": result.note,
            "recording": str(job.recording),
            "kind": job.kind,
            "tool_version": __version__,
            "timings": timings,
            "outputs": result.outputs,
            "frames": result.frames,
            "host": _HOST,
            "finished_ns": time.time_ns(),
        }
        (tmp / MARKER).write_text(json.dumps(marker, indent=1), encoding="utf-8")
        finalise(tmp, job.out_dir, job.key)
    except Exception as err:  # one recording's failure must never stop the batch
        with contextlib.suppress(OSError):
            shutil.rmtree(tmp)
        return failed_outcome(job, error_line(err), _HOST, pid)
    status: JobStatus = "partial" if result.status == "partial" else "ok"
    return JobOutcome(
        recording_id=job.recording_id,
        key=job.key,
        status=status,
        error=one_line(result.note) if result.note else "",
        timings=timings,
        outputs=result.outputs,
        frames=result.frames,
        host=_HOST,
        pid=pid,
        attempt=job.attempt,
    )


def _without_window(config: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in config.items() if k not in _WINDOW_KEYS}


def finalise(tmp: Path, final: Path, key: str) -> None:
    """Move a finished temporary folder to ``final``, replacing an older result atomically.

    An existing folder is first renamed aside (into ``.tmp``) and deleted after the new one is
    in place. If another worker finalised the same key in the meantime, ours is discarded.

    Raises:
        OSError: If the rename fails for another reason.
    """
    aside: Path | None = None
    if final.exists():
        aside = tmp.with_name(tmp.name + ".old")
        if aside.exists():
            shutil.rmtree(aside)
        try:
            final.rename(aside)
        except FileNotFoundError:  # removed by a concurrent finaliser
            aside = None
    try:
        tmp.rename(final)
    except OSError as err:
        if err.errno not in (errno.ENOTEMPTY, errno.EEXIST):
            raise
        marker = read_marker(final)
        if marker is None or marker.get("key") != key:
            raise
        shutil.rmtree(tmp)  # an identical result won the race
    if aside is not None:
        shutil.rmtree(aside, ignore_errors=True)
