"""Planning a batch: units of work per recording, their identity and idempotency keys."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from superlane_tools._version import __version__
from superlane_tools.commands.batch.manifest import BatchEntry, fingerprint, recording_id
from superlane_tools.commands.batch.status import StatusTable
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
