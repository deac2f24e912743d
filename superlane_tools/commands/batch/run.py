"""``run_batch``: plan the jobs of a batch, run them on an engine, record status, summarise."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from superlane_tools.commands.batch.engine import TMP_DIR, BatchEngine
from superlane_tools.commands.batch.engines import make_engine
from superlane_tools.commands.batch.execute import execute_plan
from superlane_tools.commands.batch.kinds import default_kind, job_kind
from superlane_tools.commands.batch.manifest import BatchEntry
from superlane_tools.commands.batch.params import BatchParams, BatchProgress, BatchReport, Tally
from superlane_tools.commands.batch.plan import config_sha256, plan_jobs
from superlane_tools.commands.batch.root import clean_stale_tmp, root_lock
from superlane_tools.commands.batch.status import RowContext, StatusTable
from superlane_tools.errors import UsageError


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
    rows = RowContext(kind_name, kind.identities(params.config), config_sha256(params.config))
    root = params.root
    engine = engine if engine is not None else make_engine(params, kind_name)
    tally = Tally(progress)
    with root_lock(root):
        clean_stale_tmp(root)
        status = StatusTable(root, params.command, {"job": kind_name, **params.config})
        planned = plan_jobs(entries, params, kind.split_sequences, status, rows, tally)
        workers = execute_plan(planned, engine, params.retries, status, rows, tally)
        summary = summarise(root, params)
    return BatchReport(
        root=root,
        status_path=status.path,
        counts=tally.counts,
        failures=tuple(sorted(tally.failures.items())),
        summary=summary,
        engine=engine.name,
        workers=workers,
        wall_s=time.perf_counter() - t0,
        engine_log=engine.log if planned else None,
    )


def summarise(root: Path, params: BatchParams) -> tuple[Path, ...]:
    """Clear the workers' folder of ``root``, then write ``root/summary/`` when asked.

    Returns:
        The summary's files (none without ``params.summary``).
    """
    # workers of a killed earlier run that were still alive at the start are gone by now
    clean_stale_tmp(root)
    with contextlib.suppress(OSError):
        (root / TMP_DIR).rmdir()  # only when empty
    if not params.summary:
        return ()
    from superlane_tools.commands.batch.summary import write_summary

    return tuple(write_summary(root, params.command))
