"""`slt compare`: a candidate run or batch root against a base, with intervals and verdicts."""

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
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.errors import ExitCode

COMPARE_EXIT_HELP = (
    f"{EXIT_CODES_HELP} With --fail-on-regression: 4 when a gated KPI is worse (outputs "
    "written; wins over 3)."
)


def _rules(values: list[str] | None) -> list[str] | None:
    from superlane_tools.errors import UsageError
    from superlane_tools.fleet import parse_rule

    for value in values or []:
        try:
            parse_rule(value)
        except UsageError as err:
            raise typer.BadParameter(str(err)) from err
    return values


def compare_cmd(
    base: Annotated[Path, typer.Argument(help="Base: a reprocess run folder or batch root.")],
    candidate: Annotated[Path, typer.Argument(help="Candidate: run folder or batch root.")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("compare"),
    fail_on_regression: Annotated[
        list[str] | None,
        typer.Option(
            "--fail-on-regression",
            metavar="KPI[:THRESHOLD]",
            help="Exit 4 when this KPI (name, family or 'all') is judged worse by more than "
            "THRESHOLD (KPI unit; percentage points for ratios). Repeatable.",
            callback=_rules,
        ),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Bootstrap seed.")] = 0,
    resamples: Annotated[
        int, typer.Option("--resamples", min=100, help="Bootstrap resamples.")
    ] = 2000,
    spans: Annotated[int, typer.Option("--spans", min=0, help="Worst spans to list.")] = 10,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip plots/*.png.")] = False,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Compare a candidate run with a base run: fleet KPI deltas with 95 % bootstrap intervals.

    BASE and CANDIDATE are each a `slt reprocess` run folder, a folder of run folders or a
    `slt batch` output root. Drives are matched by recording (content hash) and window;
    unmatched drives are listed. Writes compare.parquet (one row per sequence, drive, category
    and the fleet for every KPI), compare_spans.parquet (the worst disagreement spans),
    compare_drives.parquet, compare.md, compare.html and plots/ under --out.
    """
    from superlane_tools.commands.compare import CompareParams, compare_runs
    from superlane_tools.fleet import BootstrapParams, SpanParams, parse_rule

    with cli_errors():
        params = CompareParams(
            bootstrap=BootstrapParams(n_resamples=resamples, seed=seed),
            spans=SpanParams(max_spans=spans),
            gate=tuple(parse_rule(v) for v in fail_on_regression or []),
            plots=not no_plots,
            command=command_line(),
        )
        with new_output(out, overwrite, [base, candidate]):
            result = compare_runs(base, candidate, out, params)
    fleet = result.comparison.fleet_rows()
    counts = fleet["verdict"].value_counts()
    for row in result.differences.head(5).itertuples(index=False):
        console.print(f"differs: {row.what} {row.key}: {row.base} -> {row.candidate}", markup=False)
    summary = ", ".join(f"{counts.get(v, 0)} {v}" for v in ("worse", "better"))
    console.print(
        f"compared {len(result.comparison.matched)} matched drives: {summary}, "
        f"{len(fleet) - counts.get('worse', 0) - counts.get('better', 0)} other KPIs "
        f"-> {out}",
        markup=False,
    )
    code = report_skipped(result.skipped)
    for line in result.regressions:
        err_console.print(f"slt: regression: {line}", markup=False)
    exit_with(ExitCode.REGRESSION if result.regressions else code)


def register(app: typer.Typer) -> None:
    """Add ``slt compare`` to the root app."""
    app.command(
        "compare",
        help=inspect.cleandoc(compare_cmd.__doc__ or "") + f"\n\n{COMPARE_EXIT_HELP}",
    )(compare_cmd)
