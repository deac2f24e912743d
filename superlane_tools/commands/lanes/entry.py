"""``slt lanes``' entries: fit (``fit.py``), export-tusimple and export-kitti (``export.py``)."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.commands.lanes.export import (
    ExportResult,
    export_kitti_ego_lane,
    export_tusimple,
    parse_h_samples,
)
from superlane_tools.commands.lanes.fit import LanesFitResult, fit_masks
from superlane_tools.commands.options import OutputGuard, ProgressOpener
from superlane_tools.errors import UsageError


@dataclass(frozen=True)
class FitOptions:
    """What ``slt lanes fit`` was asked (see its options)."""

    seg_dir: Path
    camera: str
    out: Path
    classes: Path | None = None
    sequential: bool = False
    slope: bool = True
    images: Path | None = None
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def fit(options: FitOptions, progress: ProgressOpener) -> LanesFitResult:
    """Fit lanes, heading, curvature and road slope to every mask under ``seg_dir``."""
    from superlane_tools.camera import load_camera
    from superlane_tools.lanes import FitParams
    from superlane_tools.lanes.class_map import load_classes

    o = options
    cam = load_camera(o.camera)
    class_map = load_classes(o.classes if o.classes is not None else o.seg_dir / "classes.yaml")
    params = FitParams(slope=o.slope)
    with o.output_guard, progress() as bar:
        return fit_masks(
            o.seg_dir,
            cam,
            o.out,
            class_map,
            params,
            sequential=o.sequential,
            command=o.command,
            progress=bar.update,
            images_dir=o.images,
        )


@dataclass(frozen=True)
class TusimpleOptions:
    """What ``slt lanes export-tusimple`` was asked (see its options)."""

    lanes_parquet: Path
    camera: str
    out: Path
    h_samples: str = "160:720:10"
    tasks: Path | None = None
    max_lines: int = 5
    lanes: int | None = None
    raw_ext: str = ".jpg"
    output_guard: OutputGuard = field(default_factory=nullcontext)


def tusimple(options: TusimpleOptions) -> ExportResult:
    """Project fitted lanes into the image at each frame's rows; write TuSimple JSON lines.

    Raises:
        UsageError: If ``max_lines`` or ``lanes`` is below 1.
    """
    from superlane_tools.camera import load_camera
    from superlane_tools.evaluation import ExportOptions

    o = options
    if o.max_lines < 1 or (o.lanes is not None and o.lanes < 1):
        raise UsageError("--max-lines and --lanes must be at least 1")
    rows = parse_h_samples(o.h_samples)
    cam = load_camera(o.camera)
    export = ExportOptions(max_lines=o.max_lines, n_lanes=o.lanes, raw_ext=o.raw_ext)
    with o.output_guard:
        return export_tusimple(o.lanes_parquet, cam, o.out, export, h_samples=rows, tasks=o.tasks)


def kitti(
    lanes_parquet: Path, camera: str, out: Path, output_guard: OutputGuard | None = None
) -> ExportResult:
    """Rasterise each frame's fitted ego lane as a KITTI submission PNG."""
    from superlane_tools.camera import load_camera

    with output_guard or nullcontext():
        return export_kitti_ego_lane(lanes_parquet, load_camera(camera), out)
