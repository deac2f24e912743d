"""The batch engine contract: a picklable job, its outcome, and the ``BatchEngine`` protocol."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, Protocol, Self

JobStatus = Literal["ok", "partial", "failed"]
"""What one attempt at one recording gave: ``ok``, ``partial`` (outputs, some data lost),
``failed`` (no outputs)."""

TMP_DIR = ".tmp"
"""Folder under the output root where workers build a recording's outputs before the rename."""


@dataclass(frozen=True)
class Job:
    """One recording to process: the unit of work every engine schedules.

    Plain data only, so it pickles to process-pool workers and Ray tasks alike.

    Attributes:
        recording: The recording (file or ROS 2 bag folder); must be readable on the worker.
        out_dir: Final output folder ``ROOT/<recording id>``; built in ``ROOT/.tmp`` first.
        config: JSON-like job configuration (the batch config plus this recording's window).
        key: Content identity + tool version + model hashes + config hash; stored in the marker.
        kind: Job kind name (``reprocess`` or ``extract``), see :mod:`.jobs`.
        attempt: 1 for the first try, 2 for the first retry, ...
    """

    recording: Path
    out_dir: Path
    config: Mapping[str, Any]
    key: str
    kind: str = "extract"
    attempt: int = 1

    @property
    def recording_id(self) -> str:
        """Recording id: the output folder's name."""
        return self.out_dir.name

    @property
    def root(self) -> Path:
        """Output root shared by all recordings of the batch."""
        return self.out_dir.parent


@dataclass(frozen=True)
class JobOutcome:
    """What one attempt at a job gave, sent back from the worker.

    Attributes:
        recording_id: Output folder name of the recording.
        key: The job key.
        status: ``ok``, ``partial`` or ``failed``.
        error: One-line reason for ``failed`` (or what was lost for ``partial``); ``""`` if none.
        timings: Stage name -> seconds; ``total_s`` is the whole attempt on the worker.
        outputs: Number of output files written.
        frames: Frames processed (0 when the job kind has no frames).
        host: Worker host name.
        pid: Worker process id.
        attempt: Which attempt this was (1 = first).
        node: Ray node id of the worker (hex); ``""`` on the local engine, or when the worker
            died before it could tell.
    """

    recording_id: str
    key: str
    status: JobStatus
    error: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)
    outputs: int = 0
    frames: int = 0
    host: str = ""
    pid: int = 0
    attempt: int = 1
    node: str = ""


OnDone = Callable[[JobOutcome], None]
"""Called in the driver process once per finished job attempt, in completion order."""


class BatchEngine(Protocol):
    """Runs jobs on workers that each load the job kind's models once.

    Use as a context manager: entering starts the workers (and loads models), ``run`` may be
    called several times (retry rounds reuse the warm workers), leaving stops them.
    """

    name: str
    """Engine name for reports (``local``, ``ray``)."""

    @property
    def workers(self) -> int:
        """Number of parallel workers."""
        ...

    @property
    def log(self) -> Path | None:
        """File the engine's own messages went to (Ray's), or None when it has none."""
        ...

    def __enter__(self) -> Self: ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None: ...

    def run(self, jobs: Sequence[Job], on_done: OnDone) -> None:
        """Run ``jobs``; call ``on_done`` for each as it finishes; never raise for one job.

        A job whose worker crashes is reported as a ``failed`` outcome, not raised.
        """
        ...


def failed_outcome(job: Job, reason: str, host: str = "", pid: int = 0) -> JobOutcome:
    """Return the ``failed`` outcome of ``job`` with a one-line ``reason``."""
    return JobOutcome(
        recording_id=job.recording_id,
        key=job.key,
        status="failed",
        error=one_line(reason),
        host=host,
        pid=pid,
        attempt=job.attempt,
    )


def one_line(text: str, limit: int = 300) -> str:
    """Collapse ``text`` to its first non-empty line, at most ``limit`` characters."""
    lines = [ln.strip() for ln in str(text).splitlines() if ln.strip()]
    line = lines[0] if lines else "unknown error"
    return line if len(line) <= limit else line[: limit - 3] + "..."


def error_line(err: BaseException) -> str:
    """Return a one-line reason for ``err``: the message of an ``SltError``, else type + text."""
    from superlane_tools.errors import SltError

    if isinstance(err, SltError):
        return one_line(str(err))
    return one_line(f"{type(err).__name__}: {err}")
