"""``run_batch``: plan the jobs of a batch, run them on an engine, record status, summarise."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import socket
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools._version import __version__
from superlane_tools.commands.batch.engine import TMP_DIR, BatchEngine, Job, JobOutcome
from superlane_tools.commands.batch.errors import BatchError
from superlane_tools.commands.batch.kinds import default_kind, job_kind
from superlane_tools.commands.batch.manifest import BatchEntry, fingerprint, recording_id
from superlane_tools.commands.batch.status import StatusRow, StatusTable
from superlane_tools.commands.batch.worker import read_marker
from superlane_tools.errors import SltError, UsageError
from superlane_tools.reporting import input_identity

LOCK_FILE = ".batch.lock"
ENGINES = ("local", "ray")


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
    """

    root: Path
    status_path: Path
    counts: Mapping[str, int]
    failures: tuple[tuple[str, str], ...]
    summary: tuple[Path, ...]
    engine: str
    workers: int
    wall_s: float

    @property
    def total(self) -> int:
        """Recordings in the batch."""
        return sum(self.counts.values())

    @property
    def failed_fraction(self) -> float:
        """Failed recordings over those that were attempted (skipped ones excluded)."""
        attempted = self.total - self.counts.get("skipped", 0)
        return self.counts.get("failed", 0) / attempted if attempted else 0.0


class _Planned(NamedTuple):
    entry: BatchEntry
    job: Job
    sha256: str
    size_bytes: int
    mtime_ns: int


def config_sha256(config: Mapping[str, Any]) -> str:
    """Return the SHA-256 of a configuration's canonical JSON form."""
    text = json.dumps(config, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def job_key(sha256: str, kind: str, models: Mapping[str, str], config_hash: str) -> str:
    """Return the idempotency key: content + tool version + job kind + models + config."""
    text = json.dumps(
        {
            "input": sha256,
            "tool": __version__,
            "kind": kind,
            "models": dict(models),
            "config": config_hash,
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


@contextlib.contextmanager
def root_lock(root: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``root`` for one batch (released when the process dies).

    Raises:
        BatchError: If the root cannot be created or another batch holds the lock.
    """
    import fcntl

    try:
        root.mkdir(parents=True, exist_ok=True)
        handle = (root / LOCK_FILE).open("a+")
    except OSError as err:
        raise BatchError(f"output root {root} is not writable: {err.strerror}") from err
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            raise BatchError(f"another slt batch is running on {root}") from err
        yield
    finally:
        handle.close()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_stale_tmp(root: Path) -> list[Path]:
    """Remove what killed runs left: ``root/.tmp`` folders and half-written ``.*.tmp`` files.

    A folder named ``<id>.<host>.<pid>[.old]`` is kept only while that process on this host
    is alive (a local worker of a killed run exits within a second of its driver, see
    :func:`~.worker.init_worker`); with the root lock held no other batch is writing here.
    """
    from superlane_tools.commands.batch.summary import SUMMARY_DIR

    # the driver's own atomic writes (status table, summary) killed mid-write: with the lock
    # held, no process is writing them now
    removed = [p for p in root.glob(".*.tmp") if p.is_file()]
    removed += [p for p in (root / SUMMARY_DIR).glob(".*.tmp") if p.is_file()]
    for leftover in removed:
        leftover.unlink(missing_ok=True)
    tmp_root = root / TMP_DIR
    if not tmp_root.is_dir():
        return removed
    host = socket.gethostname()
    for entry in sorted(tmp_root.iterdir()):
        _, _, owner = entry.name.removesuffix(".old").partition(".")
        owner_host, _, pid_text = owner.rpartition(".")
        if pid_text.isdigit() and owner_host == host and _pid_alive(int(pid_text)):
            continue
        if entry.is_dir():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed


def make_engine(params: BatchParams, kind: str) -> BatchEngine:
    """Return the engine ``params`` asks for (not yet started).

    Raises:
        UsageError: If the engine name is unknown.
    """
    if params.engine == "local":
        from superlane_tools.commands.batch.local import LocalEngine

        if params.ray_address:
            raise UsageError("--ray-address needs --engine ray")
        return LocalEngine(kind, params.config, params.workers)
    if params.engine == "ray":
        from superlane_tools.commands.batch.ray_engine import RayEngine

        return RayEngine(kind, params.config, params.workers, params.ray_address)
    raise UsageError(f"unknown engine {params.engine!r}: use one of {ENGINES}")


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
            row_base = _identify(entry, status)
            tell("hashing", number, len(units))
            if isinstance(row_base, str):  # unreadable input: failed without a job
                rid = _fallback_id(entry)
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
                            plan.sha256,
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


def job_units(
    entries: Sequence[BatchEntry], split_sequences: bool
) -> list[tuple[BatchEntry, dict[str, Any]]]:
    """Turn entries into ``(entry, per-recording config)`` units of work.

    With ``split_sequences`` each entry is a unit and its window becomes ``start_s``/``end_s``.
    Otherwise the entries of one recording make one unit: the first entry's labels, the
    ``category`` and the sequence windows as ``segments`` (``[{start_s, stop_s, category}]``).
    """
    if split_sequences:
        return [
            (e, {k: v for k, v in (("start_s", e.start_s), ("end_s", e.end_s)) if v is not None})
            for e in entries
        ]
    groups: dict[Path, list[BatchEntry]] = {}
    for entry in entries:
        groups.setdefault(entry.path, []).append(entry)
    units: list[tuple[BatchEntry, dict[str, Any]]] = []
    for path, rows in groups.items():
        first = rows[0]
        extra: dict[str, Any] = {}
        if first.category:
            extra["category"] = first.category
        segments = [
            {
                "start_s": r.start_s or 0.0,
                "stop_s": r.end_s if r.end_s is not None else 1e9,
                "category": r.category or first.category,
            }
            for r in rows
            if r.start_s is not None or r.end_s is not None
        ]
        if segments:
            extra["segments"] = segments
        whole = BatchEntry(path, first.category, first.vehicle, first.date)
        units.append((whole, extra))
    return units


def _identify(entry: BatchEntry, status: StatusTable) -> tuple[str, int, int] | str:
    """Return ``(sha256, size_bytes, mtime_ns)`` of an entry, or a one-line reason it failed."""
    path = entry.path
    try:
        size, mtime = fingerprint(path)
        known = status.known_hash(str(path), size, mtime)
        sha = known or input_identity(path).sha256
    except OSError as err:
        return f"cannot read {path}: {err.strerror or err}"
    except SltError as err:
        return str(err)
    return sha, size, mtime


def _fallback_id(entry: BatchEntry) -> str:
    digest = hashlib.sha256(str(entry.path).encode()).hexdigest()
    return recording_id(entry, digest)


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
        sha256=sha,
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
