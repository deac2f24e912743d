"""Parquet output: atomic, written in row groups, with provenance in the schema metadata."""

from __future__ import annotations

import json
import os
from pathlib import Path
from types import TracebackType
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from superlane_tools.reporting.atomic import atomic_path
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.provenance import METADATA_KEY, Provenance

DEFAULT_ROW_GROUP = 64 * 1024


def _with_provenance(schema: pa.Schema, provenance: Provenance) -> pa.Schema:
    meta = dict(schema.metadata or {})
    meta[METADATA_KEY] = provenance.to_json().encode()
    return schema.with_metadata(meta)


def write_table(
    table: pa.Table | pd.DataFrame,
    path: str | os.PathLike[str],
    provenance: Provenance,
    row_group_size: int = DEFAULT_ROW_GROUP,
) -> Path:
    """Write a whole table to ``path`` atomically with provenance metadata.

    Args:
        table: An Arrow table or a pandas DataFrame (its index is dropped).
        path: Target ``.parquet`` path.
        provenance: Provenance stored under the ``superlane_tools`` metadata key.
        row_group_size: Rows per row group.

    Returns:
        The final path.
    """
    if isinstance(table, pd.DataFrame):
        table = pa.Table.from_pandas(table, preserve_index=False)
    table = table.replace_schema_metadata(_with_provenance(table.schema, provenance).metadata)
    with atomic_path(path, suffix=".parquet") as tmp:
        pq.write_table(table, tmp, row_group_size=row_group_size, compression="zstd")
    return Path(path)


class ParquetStreamWriter:
    """Append record batches to a Parquet file row group by row group; finalise atomically.

    Memory stays flat: each ``write`` flushes one row group. Use as a context manager; the target
    appears only when the block exits without error.
    """

    def __init__(
        self, path: str | os.PathLike[str], schema: pa.Schema, provenance: Provenance
    ) -> None:
        self.path = Path(path)
        self.schema = _with_provenance(schema, provenance)
        self.rows = 0
        self._ctx = atomic_path(self.path, suffix=".parquet")
        self._writer: pq.ParquetWriter | None = None

    def __enter__(self) -> ParquetStreamWriter:
        tmp = self._ctx.__enter__()
        self._writer = pq.ParquetWriter(tmp, self.schema, compression="zstd")
        return self

    def write(self, columns: dict[str, Any] | pa.Table | pa.RecordBatch) -> None:
        """Write one row group from a column mapping, table or record batch."""
        if self._writer is None:
            raise OutputError(f"{self.path}: writer is not open")
        if isinstance(columns, dict):
            batch = pa.Table.from_pydict(columns, schema=self.schema)
        elif isinstance(columns, pa.RecordBatch):
            batch = pa.Table.from_batches([columns]).cast(self.schema)
        else:
            batch = columns.cast(self.schema)
        if batch.num_rows:
            self._writer.write_table(batch)
            self.rows += batch.num_rows

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._writer is not None:
            self._writer.close()
        self._ctx.__exit__(exc_type, exc, tb)


def read_provenance(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Return the provenance mapping stored in a Parquet file written by this package."""
    meta = pq.read_schema(path).metadata or {}
    raw = meta.get(METADATA_KEY)
    if raw is None:
        raise OutputError(f"{path}: no superlane_tools provenance metadata")
    result: dict[str, Any] = json.loads(raw)
    return result
