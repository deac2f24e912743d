"""`slt history`: the fleet's KPIs night over night, with model changes and drifts marked."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    console,
    err_console,
    exit_with,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.errors import ExitCode

HISTORY_EXIT_HELP = (
    f"{EXIT_CODES_HELP} With --fail-on-drift: 4 when a drift no night's gate caught is found "
    "(outputs written)."
)


def _margins(values: list[str] | None) -> list[str] | None:
    for value in values or []:
        name, _, number = value.partition(":")
        try:
            float(number)
        except ValueError as err:
            raise typer.BadParameter(f"{value!r}: expected KPI:VALUE (a number)") from err
        if not name:
            raise typer.BadParameter(f"{value!r}: expected KPI:VALUE")
    return values


def history_cmd(
    root: Annotated[Path, typer.Argument(help="Nightly root holding history/ (or the dataset).")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("history_report"),
    kpi: Annotated[
        list[str] | None, typer.Option("--kpi", help="Only this KPI (repeatable; default all).")
    ] = None,
    margin: Annotated[
        list[str] | None,
        typer.Option(
            "--margin",
            metavar="KPI:VALUE",
            help="Drift margin of a KPI in its unit (ratios 0-1: 0.02 is 2 pp). Repeatable.",
            callback=_margins,
        ),
    ] = None,
    fail_on_drift: Annotated[
        bool, typer.Option("--fail-on-drift", help="Exit 4 on a drift no gate caught.")
    ] = False,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip plots/*.png.")] = False,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Plot each KPI of the fleet over the nights and flag drifts no night's gate caught.

    ROOT is a nightly root: pipelines/nightly.py appends every night's fleet summary and
    comparison to ROOT/history/ (partitioned Parquet, one folder per night). Model and
    configuration changes are marked; a drift is a decline over several nights (rules
    'decline' and 'cusum', see docs/compare.md). Writes history.md, history.html,
    history_drifts.parquet and plots/ under --out.
    """
    from superlane_tools.commands.history import HistoryParams, history_report

    margins = {}
    for value in margin or []:
        name, _, number = value.partition(":")
        margins[name] = float(number)
    with cli_errors(), new_output(out, overwrite, [root]):
        result = history_report(
            root,
            out,
            HistoryParams(tuple(kpi or ()), margins, not no_plots, command_line()),
        )
    nights = result.series["night"].nunique()
    console.print(
        f"{nights} nights, {result.series['kpi'].nunique()} KPIs, "
        f"{len(result.model_changes)} model changes, {len(result.uncaught)} drifts no gate "
        f"caught -> {out}",
        markup=False,
    )
    for line in result.drift_lines:
        err_console.print(f"slt: drift: {line}", markup=False)
    exit_with(ExitCode.REGRESSION if fail_on_drift and result.drift_lines else ExitCode.OK)


def register(app: typer.Typer) -> None:
    """Add ``slt history`` to the root app."""
    app.command(
        "history", help=inspect.cleandoc(history_cmd.__doc__ or "") + f"\n\n{HISTORY_EXIT_HELP}"
    )(history_cmd)
