"""`slt batch`: reprocess many recordings into one output root, locally or on Ray."""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    console,
    exit_with,
    note,
    progress,
    report_skipped,
)
from superlane_tools.errors import ExitCode, message_line
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from superlane_tools.commands.batch import BatchProgress, BatchReport

Manifest = Annotated[
    Path | None,
    typer.Option(
        "--manifest",
        "-m",
        help="CSV/Parquet/YAML with path and optional category, vehicle, date, sequence, "
        "start_s, end_s.",
        exists=True,
        dir_okay=False,
    ),
]


@contextmanager
def _ticker(total: int, kind: str, engine: str) -> Iterator[Callable[[BatchProgress], None]]:
    """Show the batch's progress: recordings done, their counts, failed attempts above it."""
    with progress("identify", total, "recordings") as bar:

        def tick(p: BatchProgress) -> None:
            counts = " ".join(f"{k} {v}" for k, v in p.counts.items() if v)
            name = "identify" if p.phase == "hashing" else f"{kind} ({engine})"
            bar.update(p.done, p.total, note=counts, label=name)
            last = p.last
            if last is not None and last.status == "failed":
                bar.echo(
                    message_line(
                        "note",
                        f"{last.recording_id}: attempt {last.attempt} failed: {last.error}",
                    )
                )

        yield tick


def batch_cmd(
    inputs: Annotated[
        list[Path] | None,
        typer.Argument(
            help="Recordings, ROS 2 bag folders, or folders searched recursively.",
            show_default=False,
        ),
    ] = None,
    manifest: Manifest = None,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output root; one folder per recording.")
    ] = Path("runs"),
    engine: Annotated[str, typer.Option(help="Engine: local (process pool) or ray.")] = "local",
    workers: Annotated[
        int | None,
        typer.Option(help="Parallel workers (default: CPUs of this machine or cluster).", min=1),
    ] = None,
    ray_address: Annotated[
        str | None,
        typer.Option(help="Ray cluster to join, e.g. 'auto' (default: a private local Ray)."),
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(
            "--config", help="Job configuration (TOML, YAML or JSON).", exists=True, dir_okay=False
        ),
    ] = None,
    retries: Annotated[
        int, typer.Option(help="Extra attempts for a failing recording.", min=0)
    ] = 1,
    force: Annotated[
        bool,
        typer.Option(
            "--force",
            "--overwrite",
            help="Redo recordings that already finished, replacing their folders (the root "
            "itself is reused: finished recordings are skipped without this flag).",
        ),
    ] = False,
    job: Annotated[
        str | None,
        typer.Option(help="Job per recording: reprocess or extract (default: reprocess)."),
    ] = None,
) -> None:
    """Run the per-recording job over many recordings; write status and a fleet summary.

    Each recording goes to OUT/<name>-<content hash>/, built in OUT/.tmp and renamed into
    place when complete. OUT/batch_status.parquet records every recording (ok, partial,
    failed, skipped) and is rewritten after each one; recordings already finished with the
    same content, tool version, models and config are skipped unless --force. OUT/summary/
    holds the fleet tables and report.md / report.html. Exit 3 when some recordings failed
    or lost data, 1 when all failed.
    """
    from superlane_tools.commands.batch.entry import BatchOptions, run

    options = BatchOptions(
        inputs or [],
        manifest,
        out,
        engine,
        workers,
        ray_address,
        config,
        retries,
        force,
        job,
        command_line(),
    )
    with cli_errors():
        report = run(options, lambda total, kind: _ticker(total, kind, engine))
    _print(report)


def _print(report: BatchReport) -> None:
    """Print the counts and where the status and summary are; exit with the batch's code."""
    counts = ", ".join(f"{k} {v}" for k, v in report.counts.items())
    console.print(
        f"batch: {counts} in {report.wall_s:.1f} s ({report.engine}, {report.workers} workers)",
        markup=False,
    )
    console.print(f"status: {report.status_path}", markup=False)
    if report.summary:
        console.print(f"summary: {report.summary[0].parent}", markup=False)
    if report.engine_log is not None:
        note(f"Ray's messages (node deaths, worker crashes) are in {report.engine_log}")
    lost = [Skipped("failed recordings", f"{rid}: {reason}", 1) for rid, reason in report.failures]
    if report.counts.get("partial", 0):
        detail = f"see the status table {report.status_path.name}"
        lost.append(Skipped("recordings with data lost", detail, report.counts["partial"]))
    code = report_skipped(lost)
    done = report.counts.get("ok", 0) + report.counts.get("skipped", 0)
    if report.counts.get("failed", 0) and not done and not report.counts.get("partial", 0):
        exit_with(ExitCode.ERROR)
    exit_with(code)


def register(app: typer.Typer) -> None:
    """Add this module's commands to the root app."""
    app.command(
        "batch",
        help=inspect.cleandoc(batch_cmd.__doc__ or "") + f"\n\n{EXIT_CODES_HELP}",
    )(batch_cmd)
