"""``ROOT/batch_status.parquet``: one row per recording, rewritten atomically after each job."""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import pandas as pd
import pyarrow as pa

from superlane_tools._version import __version__
from superlane_tools.commands.batch.errors import BatchError
from superlane_tools.commands.batch.manifest import BatchEntry
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import BATCH_STATUS_SCHEMA, BATCH_STATUS_TABLE
from superlane_tools.reporting.provenance import CONTENT_HASH

STATUS_FILE = BATCH_STATUS_TABLE.file
STATUSES = ("ok", "partial", "failed", "skipped")
"""``skipped``: already finished with the same key by an earlier run (outputs kept)."""

_PANDAS_DTYPES = {pa.string(): "string", pa.float64(): "float64", pa.int64(): "int64"}
COLUMNS: dict[str, str] = {f.name: _PANDAS_DTYPES[f.type] for f in BATCH_STATUS_SCHEMA}
"""Status columns and their pandas dtypes, from the table's declared schema (meanings: see
:data:`~superlane_tools.reporting.layout.BATCH_STATUS_SCHEMA`)."""


@dataclass(frozen=True)
class StatusRow:
    """One recording's line in the status table (see :data:`COLUMNS` for meanings)."""

    recording_id: str
    recording: str
    category: str
    vehicle: str
    date: str
    sequence: str
    start_s: float | None
    end_s: float | None
    content_hash: str
    size_bytes: int
    mtime_ns: int
    status: str
    result: str
    error: str
    attempts: int
    total_s: float
    timings: Mapping[str, float]
    outputs: int
    frames: int
    job: str
    models: Mapping[str, str]
    config_sha256: str
    key: str
    engine: str
    host: str
    ray_node: str = ""
    tool_version: str = __version__

    def as_record(self) -> dict[str, Any]:
        """Return the row as a column -> value mapping."""
        return {
            "recording_id": self.recording_id,
            "recording": self.recording,
            "category": self.category,
            "vehicle": self.vehicle,
            "date": self.date,
            "sequence": self.sequence,
            "start_s": float("nan") if self.start_s is None else self.start_s,
            "end_s": float("nan") if self.end_s is None else self.end_s,
            "content_hash": self.content_hash,
            "size_bytes": self.size_bytes,
            "mtime_ns": self.mtime_ns,
            "status": self.status,
            "result": self.result,
            "error": self.error,
            "attempts": self.attempts,
            "total_s": self.total_s,
            "timings_json": json.dumps(dict(self.timings), sort_keys=True),
            "outputs": self.outputs,
            "frames": self.frames,
            "job": self.job,
            "tool_version": self.tool_version,
            "models_json": json.dumps(dict(self.models), sort_keys=True),
            "config_sha256": self.config_sha256,
            "key": self.key,
            "engine": self.engine,
            "host": self.host,
            "ray_node": self.ray_node,
            "finished_ns": time.time_ns(),
        }


def empty_status() -> pd.DataFrame:
    """Return an empty status table with the right columns and dtypes."""
    return pd.DataFrame({c: pd.Series(dtype=t) for c, t in COLUMNS.items()})


def read_status(root: str | Path) -> pd.DataFrame:
    """Return ``ROOT/batch_status.parquet`` (empty with the right columns when absent).

    Raises:
        BatchError: If the file exists but cannot be read.
    """
    path = Path(root) / STATUS_FILE
    if not path.is_file():
        return empty_status()
    try:
        frame = pd.read_parquet(path)
    except Exception as err:  # pyarrow raises several types for damaged files
        raise BatchError(f"{path}: cannot read the batch status ({err}); move it away") from err
    for column, dtype in COLUMNS.items():
        if column not in frame:
            frame[column] = pd.Series(dtype=dtype)
    return frame[list(COLUMNS)].astype(COLUMNS)


class FileIdentity(NamedTuple):
    """A recording's content hash (``blake3:<hex>``), size and mtime (empty when unreadable)."""

    content_hash: str = ""
    size_bytes: int = 0
    mtime_ns: int = 0


@dataclass(frozen=True)
class RowContext:
    """What every status row of one batch shares: the job kind, model hashes, config hash."""

    kind: str
    models: Mapping[str, str]
    config_hash: str

    def row(
        self,
        entry: BatchEntry,
        rid: str,
        file: FileIdentity,
        state: str,
        result: str,
        error: str,
        key: str,
        engine: str,
        timings: Mapping[str, float] | None = None,
        outputs: int = 0,
        frames: int = 0,
        attempts: int = 0,
        host: str = "",
        ray_node: str = "",
    ) -> StatusRow:
        """Return the status row of one recording."""
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
            content_hash=file.content_hash,
            size_bytes=file.size_bytes,
            mtime_ns=file.mtime_ns,
            status=state,
            result=result,
            error=error,
            attempts=attempts,
            total_s=float(times.get("total_s", 0.0)),
            timings=times,
            outputs=outputs,
            frames=frames,
            job=self.kind,
            models=self.models,
            config_sha256=self.config_hash,
            key=key,
            engine=engine,
            host=host,
            ray_node=ray_node,
        )


class StatusTable:
    """The status table of one output root, kept in memory and rewritten on every update.

    Rows of recordings not in the current batch are kept, so the table covers every run.
    """

    def __init__(self, root: Path, command: str, config: Mapping[str, Any]) -> None:
        self.path = root / STATUS_FILE
        self._provenance = Provenance(command=command, config=dict(config))
        frame = read_status(root)
        self._rows: dict[str, dict[str, Any]] = {
            str(r["recording_id"]): {str(k): v for k, v in r.items()}
            for r in frame.to_dict(orient="records")
        }

    def previous(self, recording_id: str) -> dict[str, Any] | None:
        """Return the stored row of ``recording_id`` (from this or an earlier run), if any."""
        return self._rows.get(recording_id)

    def known_hash(self, recording: str, size_bytes: int, mtime_ns: int) -> str | None:
        """Return the content hash recorded for this path when its size and mtime are unchanged.

        Only a hash of the current algorithm (:data:`CONTENT_HASH`) counts: rows written before
        the switch to BLAKE3 (a ``sha256`` column, no ``content_hash``) make the input hashed
        again, and so get new idempotency keys.
        """
        prefix = f"{CONTENT_HASH}:"
        for row in self._rows.values():
            value = row.get("content_hash")
            if (
                row["recording"] == recording
                and int(row["size_bytes"]) == size_bytes
                and int(row["mtime_ns"]) == mtime_ns
                and isinstance(value, str)
                and value.startswith(prefix)
            ):
                return value
        return None

    def update(self, row: StatusRow, write: bool = True) -> None:
        """Insert or replace the row of ``row.recording_id``; write the file atomically."""
        self._rows[row.recording_id] = row.as_record()
        if write:
            self.write()

    def frame(self) -> pd.DataFrame:
        """Return the table, sorted by recording id."""
        if not self._rows:
            return empty_status()
        frame = pd.DataFrame(list(self._rows.values()), columns=list(COLUMNS))
        return frame.astype(COLUMNS).sort_values("recording_id", ignore_index=True)

    def write(self) -> Path:
        """Write the table to ``ROOT/batch_status.parquet`` atomically."""
        return write_table(self.frame(), self.path, self._provenance)
