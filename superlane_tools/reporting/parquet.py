"""Parquet output: atomic, written in row groups, with provenance in the schema metadata."""

from __future__ import annotations

import contextlib
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
        # not pq.write_table: on a failed write (a full disk) it leaves its writer open, and
        # the writer's __del__ prints the failing close as an ignored exception
        writer = pq.ParquetWriter(tmp, table.schema, compression="zstd")
        try:
            writer.write_table(table, row_group_size=row_group_size)
        except BaseException:
            _close(writer, failed=True)
            raise
        _close(writer, failed=False)
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
        writer, self._writer = self._writer, None
        try:
            if writer is not None:
                _close(writer, failed=exc_type is not None)
        except BaseException as err:  # the temp file goes; atomic_path names the failure
            self._ctx.__exit__(type(err), err, err.__traceback__)
            raise
        self._ctx.__exit__(exc_type, exc, tb)


def _close(writer: pq.ParquetWriter, failed: bool) -> None:
    """Close ``writer``; after a failed write (a full disk) its failing close is ignored.

    A close that raises leaves pyarrow's writer open, and its ``__del__`` would close it again
    and print the error as an ignored exception: mark it closed.
    """
    try:
        writer.close()
    except OSError:
        writer.is_open = False
        if writer.file_handle is not None:
            with contextlib.suppress(OSError):
                writer.file_handle.close()
        if not failed:
            raise


def read_provenance(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Return the provenance mapping stored in a Parquet file written by this package."""
    meta = pq.read_schema(path).metadata or {}
    raw = meta.get(METADATA_KEY)
    if raw is None:
        raise OutputError(f"{path}: no superlane_tools provenance metadata")
    result: dict[str, Any] = json.loads(raw)
    return result
