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
from superlane_tools.errors import message_line

COMPARE_EXIT_HELP = (
    f"{EXIT_CODES_HELP} With --fail-on-regression: 4 when a gated KPI regressed (significantly "
    "worse past its margin, or lost by the candidate; outputs written; wins over 3), 3 when the "
    "gate cannot decide (too few drives, no matched drive or sequence, an interval past the "
    "margin without a significant change), 0 only when every gated KPI is shown within its "
    "margin."
)


def _rules(values: list[str] | None) -> list[str] | None:
    from superlane_tools.commands.compare.entry import check_rule
    from superlane_tools.errors import UsageError

    for value in values or []:
        try:
            check_rule(value)
        except UsageError as err:
            raise typer.BadParameter(str(err)) from err
    return values


def _margins(values: list[str] | None) -> list[str] | None:
    from superlane_tools.commands.compare.entry import parse_margin
    from superlane_tools.errors import UsageError

    for value in values or []:
        try:
            parse_margin(value)
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
            metavar="KPI[:MARGIN]",
            help="Gate on this KPI (name, family or 'all'; a few primary KPIs, see compare.md): "
            "exit 4 when it regressed past MARGIN (KPI unit; percentage points for ratios; "
            "default the KPI's margin), 3 when the gate cannot decide. Repeatable; Holm across "
            "the gated KPIs.",
            callback=_rules,
        ),
    ] = None,
    margin: Annotated[
        list[str] | None,
        typer.Option(
            "--margin",
            metavar="KPI=VALUE",
            help="Margin of a KPI's verdict (KPI unit; percentage points for ratios). Repeatable.",
            callback=_margins,
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
    """Compare a candidate run with a base run: fleet KPI deltas with 95 % intervals over drives.

    BASE and CANDIDATE are each a `slt reprocess` run folder, a folder of run folders or a
    `slt batch` output root. Drives are matched by recording (content hash) and window;
    unmatched drives are listed. Writes compare.parquet (one row per sequence, drive, category
    and the fleet for every KPI), compare_spans.parquet (the worst disagreement spans),
    compare_drives.parquet, compare.md, compare.html and plots/ under --out.
    """
    from superlane_tools.commands.compare.entry import CompareOptions, run

    with cli_errors():
        options = CompareOptions(
            base,
            candidate,
            out,
            fail_on_regression or [],
            margin or [],
            seed,
            resamples,
            spans,
            not no_plots,
            command_line(),
            new_output(out, overwrite, [base, candidate]),
        )
        result = run(options)
    for line in result.differences:
        console.print(f"differs: {line}", markup=False)
    matched, n_b, n_c = result.drives
    summary = ", ".join(f"{result.verdicts[v]} {v}" for v in ("worse", "better"))
    console.print(
        f"compared {matched} matched drives (of {n_b} base, {n_c} candidate): {summary}, "
        f"{result.verdicts['other']} other KPIs -> {out}",
        markup=False,
    )
    code = report_skipped(result.skipped)
    for line in result.regressions:
        err_console.print(f"slt: regression: {line}", markup=False)
    for line in result.undecided:
        err_console.print(message_line("note", f"gate cannot decide: {line}"), markup=False)
    exit_with(max(code, result.gate_code))


def register(app: typer.Typer) -> None:
    """Add ``slt compare`` to the root app."""
    app.command(
        "compare",
        help=inspect.cleandoc(compare_cmd.__doc__ or "") + f"\n\n{COMPARE_EXIT_HELP}",
    )(compare_cmd)
