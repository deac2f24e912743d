"""Checking a built table against its declared schema (:class:`~.tables.TableSpec`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pyarrow as pa

from superlane_tools.reporting.layout.tables import DERIVED_SCHEMAS, TableSpec

if TYPE_CHECKING:
    import pandas as pd


class SchemaMismatchError(RuntimeError):
    """A built table disagrees with its declared schema (an internal error).

    A builder or the table's :class:`~.tables.TableSpec` changed without the other.
    """


def _base_type(t: pa.DataType) -> pa.DataType:
    if pa.types.is_dictionary(t):
        return _base_type(t.value_type)
    if pa.types.is_large_string(t):
        return pa.string()
    return t


def checked_table(table_spec: str | TableSpec, table: pa.Table | pd.DataFrame) -> pa.Table:
    """Return a built table as Arrow after checking it against its declared schema.

    ``table_spec`` is a spec, or the name of a derived table of a reprocess run
    (:data:`~.tables.DERIVED_SCHEMAS`). The table is returned as built (a DataFrame converted
    without its index, nothing cast), so the check never changes what is written.

    Raises:
        SchemaMismatchError: For an undeclared column, a missing required column (in a table
            with rows) or a column of another type.
    """
    if isinstance(table_spec, str):
        name, spec = table_spec, DERIVED_SCHEMAS[table_spec]
    else:
        name, spec = table_spec.name, table_spec.declared()
    if not isinstance(table, pa.Table):
        table = pa.Table.from_pandas(table, preserve_index=False)
    declared = spec.types()
    problems = []
    undeclared = [c for c in table.column_names if c not in declared]
    if undeclared:
        problems.append(f"undeclared columns {undeclared}")
    missing = [f.name for f in spec.required if f.name not in table.column_names]
    if missing and table.num_rows:
        problems.append(f"missing columns {missing}")
    for field in table.schema:
        want = declared.get(field.name)
        got = _base_type(field.type)
        if want is not None and not pa.types.is_null(got) and got != _base_type(want):
            problems.append(f"{field.name} is {field.type}, declared {want}")
    if problems:
        raise SchemaMismatchError(f"{name}: {'; '.join(problems)}")
    return table
