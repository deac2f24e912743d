"""Outputs: atomic files, Parquet with provenance, tables, plots and reports."""

from superlane_tools.reporting.atomic import atomic_path, write_bytes_atomic, write_text_atomic
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.parquet import ParquetStreamWriter, read_provenance, write_table
from superlane_tools.reporting.provenance import (
    InputIdentity,
    Provenance,
    file_sha256,
    input_identity,
)

__all__ = [
    "InputIdentity",
    "OutputError",
    "ParquetStreamWriter",
    "Provenance",
    "atomic_path",
    "file_sha256",
    "input_identity",
    "read_provenance",
    "write_bytes_atomic",
    "write_table",
    "write_text_atomic",
]
