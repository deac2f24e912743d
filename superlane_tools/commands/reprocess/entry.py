"""``slt reprocess``'s entry: the options as typed, the kernel compile, the run, its last lines.

The lane-fit kernels' compiler is opened first thing (:func:`~superlane_tools.lanes.
kernel_cache.compiling`): on a cold cache it is the run's critical path.
"""

from __future__ import annotations

from collections.abc import Iterable
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from superlane_tools.commands.options import OutputGuard, ProgressOpener

if TYPE_CHECKING:
    from superlane_tools.commands.reprocess.result import ReprocessResult

TIMES_WIDTH = 100
"""Characters of the ``times:`` line at most (the per-stage detail is in frames.parquet)."""


@dataclass(frozen=True)
class ReprocessOptions:
    """What ``slt reprocess`` was asked, as typed (see its options; None: the config's)."""

    recording: Path
    target: Path
    config: Path | None = None
    camera: str | None = None
    dbc: list[Path] = field(default_factory=list)
    backend: str | None = None
    model: str | None = None
    oracle_labels: Path | None = None
    category: str | None = None
    video: bool = False
    plots: bool = True
    workers: int | None = None
    with_signals: bool = False
    canonical_camera: bool | None = None
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


@dataclass(frozen=True)
class ReprocessOutcome:
    """The run's result and the lines the cli prints after its notes."""

    result: ReprocessResult
    signals_line: str | None
    times_line: str
    report_line: str


def _overrides(o: ReprocessOptions) -> dict[str, Any]:
    """Return the config keys the options set (options override the config file)."""
    values: dict[str, Any] = {
        "camera": o.camera,
        "can.dbcs": [str(p) for p in o.dbc] or None,
        "segmentation.backend": o.backend.lower() if o.backend is not None else None,
        "segmentation.model": o.model,
        "segmentation.oracle_labels": None if o.oracle_labels is None else str(o.oracle_labels),
        "kpi.category": o.category,
        "output.video": True if o.video else None,
        "output.plots": None if o.plots else False,
        "workers": o.workers,
        "segmentation.canonical_camera": o.canonical_camera,
    }
    return {key: value for key, value in values.items() if value is not None}


def run(options: ReprocessOptions, progress: ProgressOpener) -> ReprocessOutcome:
    """Reprocess the drive into its run folder (published whole), with the kernels compiling.

    Args:
        options: What to reprocess and how.
        progress: Opens the progress display; its note says while the kernels compile.
    """
    from superlane_tools.lanes.kernel_cache import compiling, is_compiling

    o = options
    with compiling() as compiler:  # first: on a cold cache it is this run's critical path
        from superlane_tools.commands.reprocess import reprocess_run
        from superlane_tools.drive.config import ReprocessConfig, load_config

        cfg = load_config(o.config) if o.config is not None else ReprocessConfig()
        cfg = cfg.with_overrides(_overrides(o))
        with o.output_guard, progress() as bar:

            def note() -> str:
                return "compiling lane-fit kernels" if is_compiling(compiler) else ""

            def on_phase(label: str) -> None:
                bar.phase(label, note=note())

            def on_frames(done: int, total: int | None) -> None:
                bar.update(done, total, note=note())

            result = reprocess_run(
                o.recording,
                o.target,
                cfg,
                on_frames,
                o.command,
                o.with_signals,
                compiler,
                phase=on_phase,
            )
    return ReprocessOutcome(
        result,
        _signals_line(result.signal_channels),
        times_line(result.timings, result.frames_per_s),
        report_line(o.target, result.availability),
    )


def default_config() -> str:
    """Return the default configuration as YAML (``slt reprocess --print-config``)."""
    from superlane_tools.drive.config import default_config_yaml

    return default_config_yaml()


def _signals_line(added: dict[str, int] | None) -> str | None:
    from superlane_tools.reporting.layout import ANNOTATIONS_FILE

    if added is None:
        return None
    return (
        f"{ANNOTATIONS_FILE}: added {len(added)} signal channels ({sum(added.values())} messages)"
    )


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


def report_line(target: Path, availability: Iterable[tuple[str, int, int, int]]) -> str:
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
