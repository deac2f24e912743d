"""``slt tables``: each subcommand's entry; the tables are built in ``build.py``."""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from superlane_tools.commands.tables.build import (
    availability_table,
    curvature_table,
    write_summary_table,
)
from superlane_tools.errors import UsageError
from superlane_tools.reporting.report import markdown_table

if TYPE_CHECKING:
    import pandas as pd


class TableOutput(NamedTuple):
    """What a ``slt tables`` command made: the Markdown to print, or the file it wrote."""

    text: str | None
    path: Path | None


def _emit(
    frame: pd.DataFrame,
    out: Path | None,
    runs: Sequence[Path],
    command: str,
    guard: AbstractContextManager[Any],
) -> TableOutput:
    if out is None:
        return TableOutput(markdown_table(frame), None)
    with guard:
        return TableOutput(None, write_summary_table(frame, out, runs, command))


def availability(
    runs: Sequence[Path],
    by: str,
    out: Path | None = None,
    command: str = "",
    output_guard: AbstractContextManager[Any] | None = None,
) -> TableOutput:
    """``slt tables availability``: Table II, printed (``out`` None) or written to ``out``.

    Raises:
        UsageError: If ``by`` is neither ``category`` nor ``run``.
    """
    if by not in ("category", "run"):
        raise UsageError(f"--by must be 'category' or 'run', not {by!r}")
    frame = availability_table(runs, by)
    return _emit(frame, out, runs, command, output_guard or nullcontext())


def curvature(
    runs: Sequence[Path],
    out: Path | None = None,
    command: str = "",
    output_guard: AbstractContextManager[Any] | None = None,
) -> TableOutput:
    """``slt tables curvature``: curvature errors per run, printed or written to ``out``."""
    return _emit(curvature_table(runs), out, runs, command, output_guard or nullcontext())


def paper(
    results: Sequence[Path],
    out: Path | None = None,
    command: str = "",
    output_guard: AbstractContextManager[Any] | None = None,
) -> TableOutput:
    """``slt tables paper``: the SUPER paper tables from evaluation records."""
    from superlane_tools.reporting.paper_tables import (
        load_record,
        paper_cells,
        paper_markdown,
        write_paper_tables,
    )

    sources = [str(p) for p in results]
    cells = paper_cells([load_record(p) for p in results], sources)
    if out is None:
        return TableOutput(paper_markdown(cells), None)
    with output_guard or nullcontext():
        return TableOutput(None, write_paper_tables(cells, out, sources, command))
