"""The ``local`` engine: a process pool on this machine, models loaded once per worker."""

from __future__ import annotations

import glob
import multiprocessing
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from superlane_tools.commands.batch.engine import (
    TMP_DIR,
    Job,
    OnDone,
    error_line,
    failed_outcome,
)
from superlane_tools.commands.batch.kinds import job_kind
from superlane_tools.commands.batch.worker import execute, init_worker
from superlane_tools.errors import UsageError

WORKER_MODULE = "superlane_tools.commands.batch.worker"
"""Imported once by the fork server; every worker forked from it starts with it loaded."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Native thread-pool sizes set for the workers (unless already set), so N workers share the
cores instead of each starting one thread per core."""


def default_workers() -> int:
    """Return the default number of local workers: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


class LocalEngine:
    """Run jobs in a ``ProcessPoolExecutor`` (``forkserver`` context by default).

    Each worker process runs :func:`~.worker.init_worker` once (the job kind's ONNX sessions,
    DBCs), then one recording per task. A worker that dies (segfault, out of memory) fails only
    the jobs it broke; the pool is rebuilt for the next round.

    Args:
        kind: Job kind name.
        config: Batch configuration the workers load models with.
        workers: Worker processes (default: CPUs available).
        start_method: ``forkserver`` (default: workers fork from a server that has imported the
            package once, so pools start fast) or ``spawn`` (never ``fork``: unsafe with
            threads).
    """

    name = "local"

    def __init__(
        self,
        kind: str,
        config: Mapping[str, Any],
        workers: int | None = None,
        start_method: str = "forkserver",
    ) -> None:
        if workers is not None and workers < 1:
            raise UsageError(f"--workers must be >= 1, got {workers}")
        if start_method not in {"spawn", "forkserver"}:
            raise UsageError(f"start method must be spawn or forkserver, not {start_method!r}")
        self._kind = kind
        self._config = dict(config)
        self._workers = workers or default_workers()
        self._method = start_method
        self._pool: ProcessPoolExecutor | None = None
        self._saved_env: dict[str, str | None] = {}

    @property
    def workers(self) -> int:
        """Number of worker processes."""
        return self._workers

    @property
    def log(self) -> Path | None:
        """None: the local engine prints nothing of its own."""
        return None

    def _threads(self) -> int:
        return max(1, default_workers() // self._workers)

    def _start(self) -> ProcessPoolExecutor:
        context = multiprocessing.get_context(self._method)
        if self._method == "forkserver":
            context.set_forkserver_preload([WORKER_MODULE, *job_kind(self._kind).preload])
        return ProcessPoolExecutor(
            max_workers=self._workers,
            mp_context=context,
            initializer=init_worker,
            initargs=(self._kind, self._config, self._threads(), os.getpid()),
        )

    def __enter__(self) -> Self:
        threads = str(self._threads())
        for name in THREAD_VARIABLES:
            self._saved_env[name] = os.environ.get(name)
            os.environ.setdefault(name, threads)
        self._pool = self._start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._pool is not None:
            # On an error or Ctrl-C, do not wait for queued recordings.
            self._pool.shutdown(wait=exc_type is None, cancel_futures=True)
            self._pool = None
        for name, value in self._saved_env.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value

    def run(self, jobs: Sequence[Job], on_done: OnDone) -> None:
        """Run ``jobs`` on the pool; report each outcome as it completes.

        When a worker dies, the pool breaks and every job still on it gets no result. Jobs that
        had not started yet are simply run again on a rebuilt pool; the jobs that were running
        (the dead worker's and those of the workers the pool stopped with it) are run again one
        at a time, each alone in its own pool, so a crash fails only the recording causing it.
        """
        if self._pool is None:
            raise RuntimeError("LocalEngine.run outside its context")
        interrupted = self._run_round(jobs, on_done)
        while interrupted:
            started = [job for job in interrupted if _has_started(job)]
            waiting = [job for job in interrupted if not _has_started(job)]
            for job in started:
                self._run_alone(job, on_done)
            interrupted = self._run_round(waiting, on_done) if waiting else []

    def _run_round(self, jobs: Sequence[Job], on_done: OnDone) -> list[Job]:
        """Run ``jobs`` on the pool; return those a broken pool left without an outcome."""
        assert self._pool is not None
        futures: dict[Future[Any], Job] = {
            self._pool.submit(execute, job, self._config): job for job in jobs
        }
        interrupted: list[Job] = []
        for future in as_completed(futures):
            job = futures[future]
            try:
                outcome = future.result()
            except BrokenProcessPool:
                interrupted.append(job)
                continue
            except Exception as err:  # e.g. an unpicklable result: fail this job only
                outcome = failed_outcome(job, error_line(err))
            on_done(outcome)
        if interrupted:
            self._restart()
        return interrupted

    def _run_alone(self, job: Job, on_done: OnDone) -> None:
        """Run one job by itself on the pool: a broken pool now is this job's own crash."""
        assert self._pool is not None
        try:
            outcome = self._pool.submit(execute, job, self._config).result()
        except BrokenProcessPool:
            outcome = failed_outcome(job, "worker process died (crash or out of memory)")
            self._restart()
        except Exception as err:  # e.g. an unpicklable result: fail this job only
            outcome = failed_outcome(job, error_line(err))
        on_done(outcome)

    def _restart(self) -> None:
        assert self._pool is not None
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._start()


def _has_started(job: Job) -> bool:
    """Whether a worker began ``job``: its temporary folder ``.tmp/<id>.<host>.<pid>`` exists."""
    return any((job.root / TMP_DIR).glob(f"{glob.escape(job.recording_id)}.*"))
