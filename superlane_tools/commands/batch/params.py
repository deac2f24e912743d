"""What a batch is asked to do (:class:`BatchParams`), its progress and its report."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools.commands.batch.engine import JobOutcome


@dataclass(frozen=True)
class BatchParams:
    """How to run a batch.

    Attributes:
        root: Output root; each recording goes to ``root/<recording id>/``.
        kind: Job kind (``reprocess`` or ``extract``); ``""``: ``reprocess`` when available.
        engine: ``local`` (process pool) or ``ray``.
        workers: Parallel workers; None: the CPUs of this machine (local) or cluster (ray).
        retries: Extra attempts for a failing recording before it is recorded as failed.
        force: Redo recordings that already finished with the same key.
        config: Job configuration (JSON-like mapping, e.g. read from ``--config``).
        ray_address: Ray cluster to join (``auto``); None: start a private local instance.
        command: Command line, for provenance.
        summary: Write ``root/summary/`` at the end.
    """

    root: Path
    kind: str = ""
    engine: str = "local"
    workers: int | None = None
    retries: int = 1
    force: bool = False
    config: Mapping[str, Any] = field(default_factory=dict)
    ray_address: str | None = None
    command: str = ""
    summary: bool = True


class BatchProgress(NamedTuple):
    """Progress of a batch, passed to the ``progress`` callback.

    Attributes:
        phase: ``hashing`` (identifying inputs) or ``running``.
        done: Items done in this phase.
        total: Items in this phase.
        counts: Status -> recordings so far (``ok``, ``partial``, ``failed``, ``skipped``).
        last: The latest finished job attempt, when there is one.
    """

    phase: str
    done: int
    total: int
    counts: Mapping[str, int]
    last: JobOutcome | None


@dataclass
class Tally:
    """Recordings per status so far and why each failed one failed; tells the progress callback.

    Attributes:
        progress: Called with a :class:`BatchProgress` on every :meth:`tell` (None: nobody).
        counts: Status -> recordings (``ok``, ``partial``, ``failed``, ``skipped``, in order).
        failures: Recording id -> one-line reason, of each failed recording.
    """

    progress: Callable[[BatchProgress], None] | None = None
    counts: dict[str, int] = field(
        default_factory=lambda: dict.fromkeys(("ok", "partial", "failed", "skipped"), 0)
    )
    failures: dict[str, str] = field(default_factory=dict)

    def count(self, status: str, recording_id: str, error: str = "") -> None:
        """Count one recording's final status (and the reason, when it failed)."""
        self.counts[status] += 1
        if status == "failed":
            self.failures[recording_id] = error

    def tell(self, phase: str, done: int, total: int, last: JobOutcome | None = None) -> None:
        """Report the progress of a phase, with the counts so far."""
        if self.progress is not None:
            self.progress(BatchProgress(phase, done, total, dict(self.counts), last))


@dataclass(frozen=True)
class BatchReport:
    """What a batch did.

    Attributes:
        root: Output root.
        status_path: ``root/batch_status.parquet``.
        counts: Status -> recordings in this batch.
        failures: ``(recording, one-line reason)`` of each failed recording.
        summary: Files written under ``root/summary/``.
        engine: Engine used.
        workers: Workers used.
        wall_s: Wall time of the whole batch, seconds.
        engine_log: File the engine's own messages went to (``ROOT/batch_ray.log`` with the
            Ray engine), None when there is none.
    """

    root: Path
    status_path: Path
    counts: Mapping[str, int]
    failures: tuple[tuple[str, str], ...]
    summary: tuple[Path, ...]
    engine: str
    workers: int
    wall_s: float
    engine_log: Path | None = None

    @property
    def total(self) -> int:
        """Recordings in the batch."""
        return sum(self.counts.values())

    @property
    def failed_fraction(self) -> float:
        """Failed recordings over those that were attempted (skipped ones excluded)."""
        attempted = self.total - self.counts.get("skipped", 0)
        return self.counts.get("failed", 0) / attempted if attempted else 0.0
