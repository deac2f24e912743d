"""`slt reprocess`: a drive in, every table, plot, report and Foxglove annotation out."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Annotated, Any

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    camera_option,
    check_dbc_specs,
    cli_errors,
    command_line,
    console,
    exit_with,
    model_option,
    note,
    progress,
    report_skipped,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option

TIMES_WIDTH = 100
"""Characters of the ``times:`` line at most (the per-stage detail is in frames.parquet)."""


def _recording_name(path: Path) -> str:
    return path.name.split(".")[0] if path.suffix else path.name


def _compiling(compiler: Any) -> str:
    """Return the progress note while the lane-fit kernels compile ("" when they do not)."""
    return "compiling lane-fit kernels" if compiler is not None and compiler.poll() is None else ""


def times_line(timings: dict[str, float], frames_per_s: float) -> str:
    """Return the run's times in at most :data:`TIMES_WIDTH` characters.

    Wall time, frames per second, then the stages that took the longest, as many as fit (their
    times are sums over the worker threads, so they may exceed the wall time; every frame's
    stage times are in frames.parquet).
    """
    run_keys = {"pass_wall", "post", "total"}
    stages = sorted(
        ((k, v) for k, v in timings.items() if k not in run_keys and not k.startswith("cpu_")),
        key=lambda kv: -kv[1],
    )
    line = f"times: {timings.get('total', 0.0):.1f} s wall, {frames_per_s:.1f} frames/s"
    prefix = "; stage sums: "
    top: list[str] = []
    for name, seconds in stages[:3]:
        part = f"{name} {seconds:.1f} s"
        if len(line + prefix + ", ".join([*top, part])) > TIMES_WIDTH:
            break
        top.append(part)
    return line + prefix + ", ".join(top) if top else line


def report_line(target: Path, availability: Any) -> str:
    """Return the last line: where report.html is and one availability number per method."""
    from superlane_tools.reporting.layout import REPORT_HTML_FILE
    from superlane_tools.reporting.names import AVAILABILITY_NAMES

    parts, unknown = [], []
    for method, n_frames, n_available, n_unknown in availability:
        name = AVAILABILITY_NAMES.get(method, method)
        known = n_frames - n_unknown
        if known <= 0:
            unknown.append(name)
            continue
        of = f" of {known} known" if n_unknown else ""
        parts.append(f"{name} {100.0 * n_available / known:.1f} %{of}")
    line = f"report: {target / REPORT_HTML_FILE}"
    if parts:
        line += f" -- {', '.join(parts)} of frames available"
    if unknown:
        line += f"{'; ' if parts else ' -- '}availability unknown (no speed): {', '.join(unknown)}"
    return line


def reprocess_cmd(
    recording: Annotated[
        Path | None,
        typer.Argument(
            help="Recording: MCAP, ROS 1 .bag, ROS 2 bag folder, or a dashcam video (.mp4, .mkv)."
        ),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Output folder (default runs/<name>/).")
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option("--config", help="Config file (.toml or .yaml).", exists=True, dir_okay=False),
    ] = None,
    print_config: Annotated[
        bool, typer.Option("--print-config", help="Print the default config (YAML) and exit.")
    ] = False,
    camera: Annotated[
        str | None,
        camera_option("'auto' (CameraInfo + extrinsics), a profile or a YAML.", "auto|NAME|YAML"),
    ] = None,
    dbc: Annotated[
        list[Path] | None,
        typer.Option(
            "--dbc",
            metavar="[BUS=]FILE",
            help="DBC file (repeatable; replaces the shipped DBCs); BUS=FILE binds it to one "
            "CAN bus (topic), e.g. can0=pt.dbc.",
            callback=check_dbc_specs,
        ),
    ] = None,
    backend: Annotated[
        str | None,
        typer.Option("--backend", help="Segmentation: auto, classical, onnx or oracle."),
    ] = None,
    model: Annotated[str | None, model_option("Segmentation ONNX model (path or name).")] = None,
    oracle_labels: Annotated[
        Path | None,
        typer.Option(
            "--oracle-labels",
            help="Leaf-id label PNG folder for --backend oracle.",
            exists=True,
            file_okay=False,
        ),
    ] = None,
    category: Annotated[
        str | None, typer.Option("--category", help="Category label of this drive's sequences.")
    ] = None,
    video: Annotated[bool, typer.Option("--video", help="Also write overlay.mp4.")] = False,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip plots/*.png.")] = False,
    workers: Annotated[
        int | None, typer.Option("--workers", help="Threads for the image stages.")
    ] = None,
    with_signals: Annotated[
        bool,
        typer.Option(
            "--with-signals",
            help="Add decoded CAN signals and the truth curves to annotations.mcap.",
        ),
    ] = False,
    canonical_camera: Annotated[
        bool | None,
        typer.Option(
            "--canonical-camera/--no-canonical-camera",
            help="Segment in the canonical virtual camera also with models trained without "
            "it (network backends; default off; models trained in it always use it).",
        ),
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Reprocess a drive: SUPER lane fit, corridor network, Hough baseline, CAN, RTK.

    Writes frames/lanes/corridor/baseline/availability/curvature/mobileye/rtk/can_signals
    Parquet tables, plots/*.png, report.md, report.html and annotations.mcap under --out.
    Options override the config file. Missing streams degrade gracefully and are stated in
    the report; exit code 3 means input data was lost.
    """
    from superlane_tools.errors import UsageError
    from superlane_tools.lanes.kernel_cache import start_compiling

    if print_config:
        from superlane_tools.commands.reprocess import default_config_yaml

        typer.echo(default_config_yaml(), nl=False)
        return
    with cli_errors():
        if recording is None:
            raise UsageError("missing argument RECORDING (or use --print-config)")
        target = out if out is not None else Path("runs") / _recording_name(recording)
        check_new_output(target, overwrite, [recording])
        # First: on a cold kernel cache the compiler is this run's critical path.
        compiler = start_compiling()
        try:
            from superlane_tools.commands.reprocess import (
                ReprocessConfig,
                load_config,
                reprocess_run,
            )

            cfg = load_config(config) if config is not None else ReprocessConfig()
            overrides: dict[str, Any] = {}
            if camera is not None:
                overrides["camera"] = camera
            if dbc:
                overrides["can.dbcs"] = [str(p) for p in dbc]
            if backend is not None:
                overrides["segmentation.backend"] = backend.lower()
            if model is not None:
                overrides["segmentation.model"] = model
            if oracle_labels is not None:
                overrides["segmentation.oracle_labels"] = str(oracle_labels)
            if category is not None:
                overrides["kpi.category"] = category
            if video:
                overrides["output.video"] = True
            if no_plots:
                overrides["output.plots"] = False
            if workers is not None:
                overrides["workers"] = workers
            if canonical_camera is not None:
                overrides["segmentation.canonical_camera"] = canonical_camera
            cfg = cfg.with_overrides(overrides)
            with (
                new_output(target, overwrite, [recording], replaces=True),
                progress("reprocess", unit="frames") as bar,
            ):

                def on_phase(label: str) -> None:
                    bar.phase(label, note=_compiling(compiler))

                def on_frames(done: int, total: int | None) -> None:
                    bar.update(done, total, note=_compiling(compiler))

                result = reprocess_run(
                    recording,
                    target,
                    cfg,
                    on_frames,
                    command_line(),
                    with_signals,
                    compiler,
                    phase=on_phase,
                )
        finally:
            if compiler is not None and compiler.poll() is None:
                compiler.terminate()  # the run failed, or fitted nothing: no work left behind
                compiler.wait()
        added = result.signal_channels
        if added is not None:
            from superlane_tools.reporting.layout import ANNOTATIONS_FILE

            console.print(
                f"{ANNOTATIONS_FILE}: added {len(added)} signal channels "
                f"({sum(added.values())} messages)",
                markup=False,
            )
    for line in result.notes:  # with the "Lanes not plausible" warning when there is one
        note(line)
    code = report_skipped(result.skipped)
    console.print(f"reprocessed {result.frames} frames -> {target}", markup=False)
    console.print(times_line(result.timings, result.frames_per_s), markup=False)
    console.print(report_line(target, result.availability), markup=False)
    exit_with(code)


def register(app: typer.Typer) -> None:
    """Add this module's commands to the root app."""
    app.command(
        "reprocess",
        help=inspect.cleandoc(reprocess_cmd.__doc__ or "") + f"\n\n{EXIT_CODES_HELP}",
    )(reprocess_cmd)
