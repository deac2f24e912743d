"""The ``ray`` engine: Ray tasks, one recording per task, models loaded once per worker.

Ray is an optional extra and is imported only inside these functions. With no address, a
private local Ray instance is started (and stopped afterwards), owned by a watchdog process
(:mod:`._ray_watchdog`) that stops exactly that instance's processes when the driver ends, even
by SIGKILL; ``address="auto"`` joins the
cluster started on this machine with ``ray start``; ``ray://host:10001`` or ``host:6379``
join a remote one. Every node reads the recordings and writes into the output root by the same
paths, so the root must be shared storage (NFS, a mounted object store).

Jobs run as plain Ray tasks (``num_cpus=1``, no Ray-level retries: the batch retries failed
recordings itself). Ray keeps its worker processes between tasks, and each worker loads the
job kind's models on its first task and keeps them (:func:`~.worker.init_worker` caches them
per process), so models are loaded once per worker, as with actors, but a batch does not pay
for starting a new process per worker slot: workers Ray pre-started, or kept from an earlier
batch of the same driver, are reused. A worker process that dies fails only its recording;
Ray starts a new one for the next task.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from superlane_tools.commands.batch._ray_log import ray_log
from superlane_tools.commands.batch._ray_watchdog import RayWatchdog
from superlane_tools.commands.batch.engine import Job, JobOutcome, OnDone, failed_outcome
from superlane_tools.commands.batch.errors import BatchError, EngineUnavailableError
from superlane_tools.commands.batch.worker import execute, init_worker
from superlane_tools.errors import UsageError

RAY_EXTRA = "pip install 'superlane-tools[ray]'"


def import_ray() -> Any:
    """Import Ray late, naming the extra to install when it is missing.

    Raises:
        EngineUnavailableError: If Ray is not installed.
    """
    try:
        import ray
    except ImportError as err:
        raise EngineUnavailableError(
            f"the ray engine needs Ray, which is not installed: {RAY_EXTRA}"
        ) from err
    return ray


def run_on_worker(kind: str, config: Mapping[str, Any], job: Job) -> JobOutcome:
    """Task body: load the kind's models once in this worker process, then run one job.

    The outcome carries the Ray node id of the worker (status column ``ray_node``).
    """
    init_worker(kind, config, threads=1)
    outcome = execute(job, config)
    return replace(outcome, node=import_ray().get_runtime_context().get_node_id())


class RayEngine:
    """Run jobs as Ray tasks, one recording per task, at most ``workers`` at a time.

    Args:
        kind: Job kind name.
        config: Batch configuration the workers load models with.
        workers: Concurrent tasks (default: the cluster's CPUs).
        address: Ray address to join (``auto``, ``ray://host:10001``); None: start a local one.
        num_cpus: CPUs of a locally started instance (default: Ray's own detection).
        log: File that receives Ray's own driver-side messages (node deaths, worker crashes,
            warnings) while the engine runs, instead of stdout and stderr
            (:mod:`._ray_log`); None: Ray prints them.
    """

    name = "ray"

    def __init__(
        self,
        kind: str,
        config: Mapping[str, Any],
        workers: int | None = None,
        address: str | None = None,
        num_cpus: int | None = None,
        log: Path | None = None,
    ) -> None:
        if workers is not None and workers < 1:
            raise UsageError(f"--workers must be >= 1, got {workers}")
        self._kind = kind
        self._config = dict(config)
        self._requested = workers
        self._address = address
        self._num_cpus = num_cpus
        self._ray: Any = None
        self._owns_ray = False
        self._watchdog: RayWatchdog | None = None
        self._task: Any = None
        self._config_ref: Any = None
        self._workers = 0
        self._log = log
        self._log_stack = contextlib.ExitStack()

    @property
    def log(self) -> Path | None:
        """The file Ray's messages go to (None: Ray prints them)."""
        return self._log

    @property
    def workers(self) -> int:
        """Number of concurrent tasks (known once the engine is entered)."""
        return self._workers or (self._requested or 0)

    def __enter__(self) -> Self:
        ray = import_ray()
        if self._log is not None:
            self._log_stack.enter_context(ray_log(self._log))
        try:
            self._join(ray)
        except BaseException:
            self._close_log()
            raise
        return self

    def _join(self, ray: Any) -> None:
        """Start or join Ray, size the task window, put the config in the object store."""
        self._ray = ray
        if not ray.is_initialized():
            try:
                if self._address:
                    ray.init(address=self._address, log_to_driver=False)
                else:
                    self._start_local(ray)
            except Exception as err:  # ConnectionError, RuntimeError, ... from ray.init
                where = self._address or "a local instance"
                raise BatchError(f"cannot start or join Ray at {where}: {err}") from err
            self._owns_ray = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self._workers = self._requested or max(1, cpus)
        self._task = ray.remote(num_cpus=1, max_retries=0)(run_on_worker)
        self._config_ref = ray.put(self._config)

    def _start_local(self, ray: Any) -> None:
        """Start a private instance whose processes the watchdog stops when this driver ends."""
        self._watchdog = RayWatchdog().__enter__()
        try:
            with self._watchdog.marking():
                ray.init(
                    num_cpus=self._num_cpus or self._requested,
                    include_dashboard=False,
                    log_to_driver=False,
                )
        except BaseException:
            self._stop_watchdog()
            raise

    def _stop_watchdog(self) -> None:
        watchdog, self._watchdog = self._watchdog, None
        if watchdog is not None:
            watchdog.__exit__(None, None, None)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        ray = self._ray
        if ray is None:
            return
        self._task = self._config_ref = None
        try:
            if self._owns_ray:
                try:
                    ray.shutdown()
                finally:
                    self._owns_ray = False
                    self._stop_watchdog()
        finally:
            self._close_log()

    def _close_log(self) -> None:
        self._log_stack.close()

    def _window(self) -> int:
        """Tasks to keep in flight: ``workers`` when given, else the live cluster's CPUs now.

        Only that many are submitted, so no task waits in Ray's queue, where it could be
        handed to a node that has died but is not yet declared dead; a node that joins
        during the batch widens the window, one declared dead narrows it.
        """
        if self._requested:
            return self._requested
        return max(1, int(self._ray.cluster_resources().get("CPU", 1)))

    def run(self, jobs: Sequence[Job], on_done: OnDone) -> None:
        """Run ``jobs`` as tasks, one per free CPU; a task whose worker or node died fails its job.

        A job on a node that is lost fails once Ray declares the node dead (its health checks,
        about 15 s by default); the batch then retries it on the live nodes.
        """
        ray = self._ray
        if ray is None or self._task is None:
            raise RuntimeError("RayEngine.run outside its context")
        queue = list(reversed(jobs))
        running: dict[Any, Job] = {}
        while queue or running:
            window = self._window()
            while queue and len(running) < window:
                job = queue.pop()
                running[self._task.remote(self._kind, self._config_ref, job)] = job
            ready, _ = ray.wait(list(running), num_returns=1)
            job = running.pop(ready[0])
            try:
                outcome: JobOutcome = ray.get(ready[0])
            except ray.exceptions.WorkerCrashedError as err:
                outcome = failed_outcome(job, f"Ray worker died: {type(err).__name__}")
            except ray.exceptions.RayError as err:
                outcome = failed_outcome(job, f"Ray error: {err}")
            on_done(outcome)
