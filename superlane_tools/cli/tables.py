"""`slt tables`: paper-style tables over reprocess runs and evaluation records."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    console,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option

tables_app = typer.Typer(
    name="tables",
    help=f"Aggregate reprocess runs into paper-style tables.\n\n{EXIT_CODES_HELP}",
    no_args_is_help=True,
    rich_markup_mode=None,
)

RunDirs = Annotated[list[Path], typer.Argument(help="Run folders written by slt reprocess.")]
OutFile = Annotated[
    Path | None, typer.Option("--out", "-o", help="Output .md, .tex or .parquet (default: print).")
]
Overwrite = Annotated[bool, overwrite_option()]


def _emit(frame: object, out: Path | None, runs: list[Path], overwrite: bool) -> None:
    from superlane_tools.commands.tables import write_summary_table
    from superlane_tools.reporting.report import markdown_table

    if out is None:
        typer.echo(markdown_table(frame))  # type: ignore[arg-type]
        return
    with new_output(out, overwrite, runs, replaces=True):
        path = write_summary_table(frame, out, runs, command_line())  # type: ignore[arg-type]
    console.print(f"wrote {path}", markup=False)


@tables_app.command("availability")
def availability_cmd(
    runs: RunDirs,
    out: OutFile = None,
    by: Annotated[
        str, typer.Option("--by", help="Group rows by 'category' (from --category) or 'run'.")
    ] = "category",
    overwrite: Overwrite = False,
) -> None:
    """Corridor paper Table II: #seq, frame-based n/N and sequence-based k/K per method."""
    from superlane_tools.commands.tables import availability_table
    from superlane_tools.errors import UsageError

    with cli_errors():
        check_new_output(out, overwrite, runs)
        if by not in ("category", "run"):
            raise UsageError(f"--by must be 'category' or 'run', not {by!r}")
        _emit(availability_table(runs, by), out, runs, overwrite)


@tables_app.command("curvature")
def curvature_cmd(runs: RunDirs, out: OutFile = None, overwrite: Overwrite = False) -> None:
    """Curvature errors against RTK per run: SUPER (2*a2) and Mobileye (2*C2)."""
    from superlane_tools.commands.tables import curvature_table

    with cli_errors():
        check_new_output(out, overwrite, runs)
        _emit(curvature_table(runs), out, runs, overwrite)


@tables_app.command("paper")
def paper_cmd(
    results: Annotated[
        list[Path], typer.Argument(help="Evaluation records written by `slt eval ... --save`.")
    ],
    out: OutFile = None,
    overwrite: Overwrite = False,
) -> None:
    """SUPER paper Tables 2-4 and the Fig. 9 modes from evaluation records (docs/evaluation.md)."""
    from superlane_tools.reporting.paper_tables import (
        load_record,
        paper_cells,
        paper_markdown,
        write_paper_tables,
    )

    with cli_errors():
        check_new_output(out, overwrite, results)
        sources = [str(p) for p in results]
        cells = paper_cells([load_record(p) for p in results], sources)
        if out is None:
            typer.echo(paper_markdown(cells))
            return
        with new_output(out, overwrite, results):
            path = write_paper_tables(cells, out, sources, command_line())
    console.print(f"wrote {path}", markup=False)


def register(app: typer.Typer) -> None:
    """Add the ``tables`` command group to the root app."""
    app.add_typer(tables_app, name="tables")
