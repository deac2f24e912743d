"""``run_batch``: plan the jobs of a batch, run them on an engine, record status, summarise."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

from superlane_tools.commands.batch.engine import TMP_DIR, BatchEngine, Job, JobOutcome
from superlane_tools.commands.batch.engines import make_engine
from superlane_tools.commands.batch.kinds import default_kind, job_kind
from superlane_tools.commands.batch.manifest import BatchEntry, recording_id
from superlane_tools.commands.batch.params import BatchParams, BatchProgress, BatchReport
from superlane_tools.commands.batch.plan import (
    config_sha256,
    fallback_id,
    identify,
    job_key,
    job_units,
)
from superlane_tools.commands.batch.root import clean_stale_tmp, root_lock
from superlane_tools.commands.batch.status import StatusRow, StatusTable
from superlane_tools.commands.batch.worker import read_marker
from superlane_tools.errors import UsageError


class _Planned(NamedTuple):
    entry: BatchEntry
    job: Job
    content_hash: str
    size_bytes: int
    mtime_ns: int


def run_batch(
    entries: Sequence[BatchEntry],
    params: BatchParams,
    progress: Callable[[BatchProgress], None] | None = None,
    engine: BatchEngine | None = None,
) -> BatchReport:
    """Process every entry into ``params.root``, idempotently, and write the status and summary.

    Recordings already finished with the same key are skipped (unless ``force``); failing ones
    are retried ``params.retries`` times, then recorded as failed; the status table is rewritten
    after every completion, so a killed batch loses nothing that finished.

    Args:
        entries: Recordings (and sequences) to process.
        params: How to run.
        progress: Called after each recording is identified and after each job attempt.
        engine: An engine to use instead of the one ``params`` names (not yet entered).

    Returns:
        Counts, failures and the files written.

    Raises:
        UsageError: On bad parameters or configuration.
        BatchError: If the root is unwritable or locked, or the engine cannot start.
    """
    t0 = time.perf_counter()
    if params.retries < 0:
        raise UsageError(f"--retries must be >= 0, got {params.retries}")
    if not entries:
        raise UsageError("no recordings to process")
    kind_name = params.kind or default_kind()
    kind = job_kind(kind_name)
    kind.check(params.config)
    models = kind.identities(params.config)
    config_hash = config_sha256(params.config)
    root = params.root
    engine = engine if engine is not None else make_engine(params, kind_name)
    with root_lock(root):
        clean_stale_tmp(root)
        status = StatusTable(root, params.command, {"job": kind_name, **params.config})
        counts = dict.fromkeys(("ok", "partial", "failed", "skipped"), 0)
        failures: dict[str, str] = {}

        def tell(phase: str, done: int, total: int, last: JobOutcome | None = None) -> None:
            if progress is not None:
                progress(BatchProgress(phase, done, total, dict(counts), last))

        planned: list[_Planned] = []
        seen: set[str] = set()
        units = job_units(entries, kind.split_sequences)
        for number, (entry, window) in enumerate(units, start=1):
            row_base = identify(entry, status)
            tell("hashing", number, len(units))
            if isinstance(row_base, str):  # unreadable input: failed without a job
                rid = fallback_id(entry)
                counts["failed"] += 1
                failures[rid] = row_base
                status.update(
                    _row(
                        entry,
                        rid,
                        "",
                        0,
                        0,
                        "failed",
                        "failed",
                        row_base,
                        kind_name,
                        models,
                        config_hash,
                        "",
                        params.engine,
                    )
                )
                continue
            sha, size, mtime = row_base
            rid = recording_id(entry, sha)
            if rid in seen:
                continue  # the same content (and window) listed twice
            seen.add(rid)
            key = job_key(sha, kind_name, models, config_sha256({**params.config, **window}))
            out_dir = root / rid
            marker = read_marker(out_dir)
            if marker is not None and marker.get("key") == key and not params.force:
                counts["skipped"] += 1
                done_status = str(marker.get("status", "ok"))
                status.update(
                    _row(
                        entry,
                        rid,
                        sha,
                        size,
                        mtime,
                        "skipped",
                        done_status,
                        str(marker.get("note", "")),
                        kind_name,
                        models,
                        config_hash,
                        key,
                        params.engine,
                        timings=marker.get("timings") or {},
                        outputs=int(marker.get("outputs", 0)),
                        frames=int(marker.get("frames", 0)),
                        attempts=0,
                    ),
                    write=False,
                )
                continue
            job = Job(entry.path, out_dir, {**params.config, **window}, key, kind_name)
            planned.append(_Planned(entry, job, sha, size, mtime))
        status.write()

        by_id = {p.job.recording_id: p for p in planned}
        total = len(planned)
        finished = 0
        workers = 0
        with engine if planned else contextlib.nullcontext(engine):
            pending = [p.job for p in planned]
            for attempt in range(1, params.retries + 2):
                retry: list[Job] = []

                def on_done(
                    outcome: JobOutcome, attempt: int = attempt, retry: list[Job] = retry
                ) -> None:
                    nonlocal finished
                    plan = by_id[outcome.recording_id]
                    last_try = attempt > params.retries
                    if outcome.status == "failed" and not last_try:
                        retry.append(
                            Job(
                                plan.job.recording,
                                plan.job.out_dir,
                                plan.job.config,
                                plan.job.key,
                                plan.job.kind,
                                attempt + 1,
                            )
                        )
                    else:
                        finished += 1
                        counts[outcome.status] += 1
                        if outcome.status == "failed":
                            failures[outcome.recording_id] = outcome.error
                    status.update(
                        _row(
                            plan.entry,
                            outcome.recording_id,
                            plan.content_hash,
                            plan.size_bytes,
                            plan.mtime_ns,
                            outcome.status,
                            outcome.status,
                            outcome.error,
                            kind_name,
                            models,
                            config_hash,
                            outcome.key,
                            engine.name,
                            timings=outcome.timings,
                            outputs=outcome.outputs,
                            frames=outcome.frames,
                            attempts=attempt,
                            host=outcome.host,
                        )
                    )
                    tell("running", finished, total, outcome)

                if pending:
                    engine.run(pending, on_done)
                pending = retry
            workers = engine.workers if planned else 0
        # workers of a killed earlier run that were still alive at the start are gone by now
        clean_stale_tmp(root)
        with contextlib.suppress(OSError):
            (root / TMP_DIR).rmdir()  # only when empty
        summary: tuple[Path, ...] = ()
        if params.summary:
            from superlane_tools.commands.batch.summary import write_summary

            summary = tuple(write_summary(root, params.command))
    return BatchReport(
        root=root,
        status_path=status.path,
        counts=counts,
        failures=tuple(sorted(failures.items())),
        summary=summary,
        engine=engine.name,
        workers=workers,
        wall_s=time.perf_counter() - t0,
    )


def _row(
    entry: BatchEntry,
    rid: str,
    sha: str,
    size: int,
    mtime: int,
    state: str,
    result: str,
    error: str,
    kind: str,
    models: Mapping[str, str],
    config_hash: str,
    key: str,
    engine: str,
    timings: Mapping[str, float] | None = None,
    outputs: int = 0,
    frames: int = 0,
    attempts: int = 0,
    host: str = "",
) -> StatusRow:
    times = dict(timings or {})
    return StatusRow(
        recording_id=rid,
        recording=str(entry.path),
        category=entry.category,
        vehicle=entry.vehicle,
        date=entry.date,
        sequence=entry.sequence,
        start_s=entry.start_s,
        end_s=entry.end_s,
        content_hash=sha,
        size_bytes=size,
        mtime_ns=mtime,
        status=state,
        result=result,
        error=error,
        attempts=attempts,
        total_s=float(times.get("total_s", 0.0)),
        timings=times,
        outputs=outputs,
        frames=frames,
        job=kind,
        models=models,
        config_sha256=config_hash,
        key=key,
        engine=engine,
        host=host,
    )
