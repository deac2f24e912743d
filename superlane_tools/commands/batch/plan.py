"""Planning a batch: units of work per recording, their identity and idempotency keys, the jobs."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools._version import __version__
from superlane_tools.commands.batch.engine import Job
from superlane_tools.commands.batch.manifest import BatchEntry, fingerprint, recording_id
from superlane_tools.commands.batch.params import BatchParams, Tally
from superlane_tools.commands.batch.status import FileIdentity, RowContext, StatusRow, StatusTable
from superlane_tools.commands.batch.worker import read_marker
from superlane_tools.errors import SltError
from superlane_tools.reporting import input_identity


def config_sha256(config: Mapping[str, Any]) -> str:
    """Return the SHA-256 of a configuration's canonical JSON form."""
    text = json.dumps(config, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def job_key(content_hash: str, kind: str, models: Mapping[str, str], config_hash: str) -> str:
    """Return the idempotency key: content + tool version + job kind + models + config.

    ``content_hash`` carries its algorithm (``blake3:...``), so a key made from an older SHA-256
    identity never equals one made from a BLAKE3 identity: such work runs again.
    """
    text = json.dumps(
        {
            "input": content_hash,
            "tool": __version__,
            "kind": kind,
            "models": dict(models),
            "config": config_hash,
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


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


def identify(entry: BatchEntry, status: StatusTable) -> tuple[str, int, int] | str:
    """Return ``(content_hash, size_bytes, mtime_ns)`` of an entry, or why it failed (one line).

    The content hash is :func:`input_identity`'s (``blake3:<hex>``); one recorded in the status
    table for the same path, size and mtime is reused when it has the same algorithm.
    """
    path = entry.path
    try:
        size, mtime = fingerprint(path)
        known = status.known_hash(str(path), size, mtime)
        sha = known or input_identity(path).content_hash
    except OSError as err:
        return f"cannot read {path}: {err.strerror or err}"
    except SltError as err:
        return str(err)
    return sha, size, mtime


def fallback_id(entry: BatchEntry) -> str:
    """Return a recording id for an entry that could not be hashed (from its path)."""
    digest = hashlib.sha256(str(entry.path).encode()).hexdigest()
    return recording_id(entry, digest)


class PlannedJob(NamedTuple):
    """A job to run, with what its status rows need: the entry and the input's identity."""

    entry: BatchEntry
    job: Job
    file: FileIdentity


def plan_jobs(
    entries: Sequence[BatchEntry],
    params: BatchParams,
    split_sequences: bool,
    status: StatusTable,
    rows: RowContext,
    tally: Tally,
) -> list[PlannedJob]:
    """Identify each unit of work and return the jobs to run; record the others in ``status``.

    An unreadable input is counted and recorded ``failed`` without a job; one that an earlier
    run finished with the same key, ``skipped`` (unless ``params.force``); the same content (and
    window) listed twice runs once. The status table is written at the end.

    Args:
        entries: Recordings (and sequences) of the batch.
        params: How to run (root, config, force, engine name for the rows).
        split_sequences: Each sequence is a unit of its own (see :func:`job_units`).
        status: The root's status table.
        rows: What every status row shares (job kind, models, config hash).
        tally: Counts and failures so far; told each input identified (phase ``hashing``).
    """
    planned: list[PlannedJob] = []
    seen: set[str] = set()
    units = job_units(entries, split_sequences)
    for number, (entry, window) in enumerate(units, start=1):
        identity = identify(entry, status)
        tally.tell("hashing", number, len(units))
        if isinstance(identity, str):  # unreadable input: failed without a job
            rid = fallback_id(entry)
            tally.count("failed", rid, identity)
            failed = rows.row(
                entry, rid, FileIdentity(), "failed", "failed", identity, "", params.engine
            )
            status.update(failed)
            continue
        file = FileIdentity(*identity)
        rid = recording_id(entry, file.content_hash)
        if rid in seen:
            continue  # the same content (and window) listed twice
        seen.add(rid)
        config = {**params.config, **window}
        key = job_key(file.content_hash, rows.kind, rows.models, config_sha256(config))
        out_dir = params.root / rid
        marker = read_marker(out_dir)
        if marker is not None and marker.get("key") == key and not params.force:
            tally.count("skipped", rid)
            skipped = _finished_row(rows, entry, rid, file, marker, key, params.engine)
            status.update(skipped, write=False)
            continue
        job = Job(entry.path, out_dir, config, key, rows.kind)
        planned.append(PlannedJob(entry, job, file))
    status.write()
    return planned


def _finished_row(
    rows: RowContext,
    entry: BatchEntry,
    rid: str,
    file: FileIdentity,
    marker: Mapping[str, Any],
    key: str,
    engine: str,
) -> StatusRow:
    """Return the ``skipped`` row of a recording an earlier run finished, from its marker."""
    return rows.row(
        entry,
        rid,
        file,
        "skipped",
        str(marker.get("status", "ok")),
        str(marker.get("note", "")),
        key,
        engine,
        timings=marker.get("timings") or {},
        outputs=int(marker.get("outputs", 0)),
        frames=int(marker.get("frames", 0)),
    )
