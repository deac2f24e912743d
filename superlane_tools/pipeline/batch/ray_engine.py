"""The ``ray`` engine: one actor per worker slot, models loaded once per actor.

Ray is an optional extra and is imported only inside these functions. With no address, a
private local Ray instance is started (and stopped afterwards); ``address="auto"`` joins the
cluster started on this machine with ``ray start``; ``ray://host:10001`` or ``host:6379``
join a remote one. Every node reads the recordings and writes into the output root by the same
paths, so the root must be shared storage (NFS, a mounted object store).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import TracebackType
from typing import Any, Self

from superlane_tools.errors import UsageError
from superlane_tools.pipeline.batch.engine import Job, JobOutcome, OnDone, failed_outcome
from superlane_tools.pipeline.batch.errors import BatchError, EngineUnavailableError
from superlane_tools.pipeline.batch.worker import execute, init_worker

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


class RayWorker:
    """Actor body: loads the job kind's models in ``__init__``, then runs one job per call."""

    def __init__(self, kind: str, config: Mapping[str, Any]) -> None:
        self._config = dict(config)
        init_worker(kind, self._config, threads=1)

    def run(self, job: Job) -> JobOutcome:
        """Run one job on this actor (never raises for the job)."""
        return execute(job, self._config)


class RayEngine:
    """Run jobs as calls on a pool of Ray actors, one recording per call.

    Args:
        kind: Job kind name.
        config: Batch configuration the actors load models with.
        workers: Actors (default: the cluster's CPUs).
        address: Ray address to join (``auto``, ``ray://host:10001``); None: start a local one.
        num_cpus: CPUs of a locally started instance (default: Ray's own detection).
    """

    name = "ray"

    def __init__(
        self,
        kind: str,
        config: Mapping[str, Any],
        workers: int | None = None,
        address: str | None = None,
        num_cpus: int | None = None,
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
        self._actor_cls: Any = None
        self._actors: list[Any] = []

    @property
    def workers(self) -> int:
        """Number of actors (known once the engine is entered)."""
        return len(self._actors) or (self._requested or 0)

    def __enter__(self) -> Self:
        ray = import_ray()
        self._ray = ray
        if not ray.is_initialized():
            try:
                if self._address:
                    ray.init(address=self._address, log_to_driver=False)
                else:
                    ray.init(
                        num_cpus=self._num_cpus or self._requested,
                        include_dashboard=False,
                        log_to_driver=False,
                    )
            except Exception as err:  # ConnectionError, RuntimeError, ... from ray.init
                where = self._address or "a local instance"
                raise BatchError(f"cannot start or join Ray at {where}: {err}") from err
            self._owns_ray = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        count = self._requested or max(1, cpus)
        self._actor_cls = ray.remote(num_cpus=1)(RayWorker)
        self._actors = [self._actor_cls.remote(self._kind, self._config) for _ in range(count)]
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        ray = self._ray
        if ray is None:
            return
        for actor in self._actors:
            ray.kill(actor)
        self._actors = []
        if self._owns_ray:
            ray.shutdown()
            self._owns_ray = False

    def run(self, jobs: Sequence[Job], on_done: OnDone) -> None:
        """Schedule ``jobs`` on idle actors; replace an actor that dies and fail its job."""
        ray = self._ray
        if ray is None:
            raise RuntimeError("RayEngine.run outside its context")
        queue = list(reversed(jobs))
        idle = list(self._actors)
        running: dict[Any, tuple[Job, Any]] = {}
        while queue or running:
            while queue and idle:
                job = queue.pop()
                actor = idle.pop()
                running[actor.run.remote(job)] = (job, actor)
            ready, _ = ray.wait(list(running), num_returns=1)
            ref = ready[0]
            job, actor = running.pop(ref)
            try:
                outcome: JobOutcome = ray.get(ref)
            except ray.exceptions.RayActorError as err:
                outcome = failed_outcome(job, f"Ray worker died: {type(err).__name__}")
                self._actors.remove(actor)
                actor = self._actor_cls.remote(self._kind, self._config)
                self._actors.append(actor)
            except ray.exceptions.RayError as err:
                outcome = failed_outcome(job, f"Ray error: {err}")
            idle.append(actor)
            on_done(outcome)
