"""`slt batch`: reprocess many recordings into one output root, locally or on Ray."""

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
    exit_with,
    note,
    progress,
    report_skipped,
)
from superlane_tools.errors import ExitCode, UsageError, message_line
from superlane_tools.records import Skipped


def batch_cmd(
    inputs: Annotated[
        list[Path] | None,
        typer.Argument(
            help="Recordings, ROS 2 bag folders, or folders searched recursively.",
            show_default=False,
        ),
    ] = None,
    manifest: Annotated[
        Path | None,
        typer.Option(
            "--manifest",
            "-m",
            help="CSV/Parquet/YAML with path and optional category, vehicle, date, sequence, "
            "start_s, end_s.",
            exists=True,
            dir_okay=False,
        ),
    ] = None,
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
    from superlane_tools.commands.batch import (
        BatchParams,
        BatchProgress,
        default_kind,
        expand_inputs,
        load_config_file,
        read_manifest,
        run_batch,
    )

    with cli_errors():
        if bool(inputs) == (manifest is not None):
            raise UsageError("give recordings/folders or --manifest FILE (one of the two)")
        entries = read_manifest(manifest) if manifest is not None else expand_inputs(inputs or [])
        params = BatchParams(
            root=out,
            kind=job or default_kind(),
            engine=engine.lower(),
            workers=workers,
            retries=retries,
            force=force,
            config=load_config_file(config) if config is not None else {},
            ray_address=ray_address,
            command=command_line(),
        )
        with progress("identify", len(entries), "recordings") as bar:

            def tick(p: BatchProgress) -> None:
                counts = " ".join(f"{k} {v}" for k, v in p.counts.items() if v)
                name = "identify" if p.phase == "hashing" else f"{params.kind} ({engine})"
                bar.update(p.done, p.total, note=counts, label=name)
                last = p.last
                if last is not None and last.status == "failed":
                    bar.echo(
                        message_line(
                            "note",
                            f"{last.recording_id}: attempt {last.attempt} failed: {last.error}",
                        )
                    )

            report = run_batch(entries, params, progress=tick)
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
