"""``slt tables``: paper-style tables over reprocess runs and evaluation records."""

from superlane_tools.commands.tables.build import (
    TABLE_FORMATS,
    availability_table,
    curvature_table,
    write_summary_table,
)
from superlane_tools.commands.tables.run import TableOutput, availability, curvature, paper

__all__ = [
    "TABLE_FORMATS",
    "TableOutput",
    "availability",
    "availability_table",
    "curvature",
    "curvature_table",
    "paper",
    "write_summary_table",
]
