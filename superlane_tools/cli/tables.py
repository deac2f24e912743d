"""`slt tables`: paper-style tables over reprocess runs and evaluation records."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    console,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option

if TYPE_CHECKING:
    from superlane_tools.commands.tables import TableOutput

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


def _print(output: TableOutput) -> None:
    if output.path is None:
        typer.echo(output.text)
        return
    console.print(f"wrote {output.path}", markup=False)


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
    from superlane_tools.commands.tables import availability

    with cli_errors():
        check_new_output(out, overwrite, runs)
        guard = new_output(out, overwrite, runs, replaces=True)
        output = availability(runs, by, out, command_line(), guard)
    _print(output)


@tables_app.command("curvature")
def curvature_cmd(runs: RunDirs, out: OutFile = None, overwrite: Overwrite = False) -> None:
    """Curvature errors against RTK per run: SUPER (2*a2) and Mobileye (2*C2)."""
    from superlane_tools.commands.tables import curvature

    with cli_errors():
        check_new_output(out, overwrite, runs)
        guard = new_output(out, overwrite, runs, replaces=True)
        output = curvature(runs, out, command_line(), guard)
    _print(output)


@tables_app.command("paper")
def paper_cmd(
    results: Annotated[
        list[Path], typer.Argument(help="Evaluation records written by `slt eval ... --save`.")
    ],
    out: OutFile = None,
    overwrite: Overwrite = False,
) -> None:
    """SUPER paper Tables 2-4 and the Fig. 9 modes from evaluation records (docs/evaluation.md)."""
    from superlane_tools.commands.tables import paper

    with cli_errors():
        check_new_output(out, overwrite, results)
        output = paper(results, out, command_line(), new_output(out, overwrite, results))
    _print(output)


def register(app: typer.Typer) -> None:
    """Add the ``tables`` command group to the root app."""
    app.add_typer(tables_app, name="tables")
