"""``run_batch``: plan the jobs of a batch, run them on an engine, record status, summarise."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
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
from superlane_tools.commands.batch.status import FileIdentity, RowContext, StatusTable
from superlane_tools.commands.batch.worker import read_marker
from superlane_tools.errors import UsageError


class _Planned(NamedTuple):
    entry: BatchEntry
    job: Job
    file: FileIdentity


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
    rows = RowContext(kind_name, models, config_sha256(params.config))
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
                no_file = FileIdentity()
                status.update(
                    rows.row(entry, rid, no_file, "failed", "failed", row_base, "", params.engine)
                )
                continue
            file = FileIdentity(*row_base)
            rid = recording_id(entry, file.content_hash)
            if rid in seen:
                continue  # the same content (and window) listed twice
            seen.add(rid)
            window_hash = config_sha256({**params.config, **window})
            key = job_key(file.content_hash, kind_name, models, window_hash)
            out_dir = root / rid
            marker = read_marker(out_dir)
            if marker is not None and marker.get("key") == key and not params.force:
                counts["skipped"] += 1
                done_status, note = str(marker.get("status", "ok")), str(marker.get("note", ""))
                skipped = rows.row(
                    entry,
                    rid,
                    file,
                    "skipped",
                    done_status,
                    note,
                    key,
                    params.engine,
                    timings=marker.get("timings") or {},
                    outputs=int(marker.get("outputs", 0)),
                    frames=int(marker.get("frames", 0)),
                )
                status.update(skipped, write=False)
                continue
            job = Job(entry.path, out_dir, {**params.config, **window}, key, kind_name)
            planned.append(_Planned(entry, job, file))
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
                        retry.append(replace(plan.job, attempt=attempt + 1))
                    else:
                        finished += 1
                        counts[outcome.status] += 1
                        if outcome.status == "failed":
                            failures[outcome.recording_id] = outcome.error
                    row = rows.row(
                        plan.entry,
                        outcome.recording_id,
                        plan.file,
                        outcome.status,
                        outcome.status,
                        outcome.error,
                        outcome.key,
                        engine.name,
                        timings=outcome.timings,
                        outputs=outcome.outputs,
                        frames=outcome.frames,
                        attempts=attempt,
                        host=outcome.host,
                        ray_node=outcome.node,
                    )
                    status.update(row)
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
        engine_log=engine.log if planned else None,
    )
