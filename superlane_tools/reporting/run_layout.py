"""Every output file of a run by name, and every output table's schema, defined once.

A reprocess run folder (``slt reprocess -o RUN``, or one recording of ``slt batch``) holds::

    frames.parquet  lanes.parquet  corridor.parquet  baseline.parquet     streamed per frame
    can_signals.parquet  mobileye.parquet  rtk.parquet                      derived after the pass
    curvature.parquet  curvature_summary.parquet
    availability_frames.parquet  availability_sequences.parquet
    annotations.mcap  overlay.mp4 (--video)  plots/*.png  report.md  report.html
    run_manifest.json                                                       written last

Use :class:`RunLayout` for paths inside one run (``RunLayout(root).lanes``), the ``*_FILE``
constants where only a name is needed, :func:`is_reprocess_run` to recognise a run folder, and
the ``*_SCHEMA`` constants for the Arrow schema of every streamed table. ``slt extract``'s folder
(:class:`ExtractLayout`) and the batch summary (:class:`SummaryLayout`) are named here too, so
that ``slt tables``, ``slt batch``, ``slt compare`` and ``slt mine`` read what reprocess wrote
by the same names. The lanes columns come from :data:`superlane_tools.lanes.table.FIT_COLUMNS`
(the lane layer builds the rows); every other schema is defined in this module.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import overload

import pyarrow as pa

from superlane_tools.lanes.table import FIT_COLUMNS

# ---- file names of a reprocess run --------------------------------------------------------
FRAMES_FILE = "frames.parquet"
LANES_FILE = "lanes.parquet"
CORRIDOR_FILE = "corridor.parquet"
BASELINE_FILE = "baseline.parquet"
CAN_SIGNALS_FILE = "can_signals.parquet"
MOBILEYE_FILE = "mobileye.parquet"
RTK_FILE = "rtk.parquet"
CURVATURE_FILE = "curvature.parquet"
CURVATURE_SUMMARY_FILE = "curvature_summary.parquet"
AVAILABILITY_FRAMES_FILE = "availability_frames.parquet"
AVAILABILITY_SEQUENCES_FILE = "availability_sequences.parquet"
ANNOTATIONS_FILE = "annotations.mcap"
OVERLAY_FILE = "overlay.mp4"
REPORT_FILE = "report.md"
"""The report; ``report.html`` (:data:`REPORT_HTML_FILE`) is written beside it."""
REPORT_HTML_FILE = "report.html"
PLOTS_DIR = "plots"
"""Folder of the plots: the ``*_PLOT`` files and :func:`example_plot_name`."""
CURVATURE_TIME_PLOT = "curvature_time.png"
CURVATURE_DISTANCE_PLOT = "curvature_distance.png"
AVAILABILITY_PLOT = "availability_timeline.png"
MANIFEST_FILE = "run_manifest.json"
"""Written last: a run folder without it is incomplete (see :mod:`.run_folder`)."""

STREAMED_TABLES = ("frames", "lanes", "corridor", "baseline")
"""Tables written while the frames stream, one row per camera frame."""
DERIVED_TABLES = (
    "can_signals",
    "mobileye",
    "rtk",
    "curvature",
    "curvature_summary",
    "availability_frames",
    "availability_sequences",
)
"""Tables derived after the pass (the fields of ``drive.DriveTables`` of the same names)."""

# ---- file names of other commands' folders ------------------------------------------------
CAN_RAW_FILE = "can_raw.parquet"
CAMERA_INFO_FILE = "camera_info.parquet"
FLEET_STATUS_FILE = "fleet_status.parquet"
AVAILABILITY_BY_CATEGORY_FILE = "availability_by_category.parquet"
CURVATURE_BY_RECORDING_FILE = "curvature_by_recording.parquet"
SUMMARY_DIR = "summary"
"""``slt batch``'s fleet summary folder under the output root."""
NIGHTLY_COMPARE_DIR = "compare"
"""``pipelines/nightly.py --baseline``: the comparison with the baseline, under the summary."""
NIGHTLY_MINED_DIR = "mined"
"""``pipelines/nightly.py --baseline``: the frames worth labelling, under the summary."""
BATCH_STATUS_FILE = "batch_status.parquet"
"""``slt batch``'s status table at the output root, one row per recording."""


class _File:
    """A path inside a layout's root, by file name (a read-only attribute of the layout)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.__doc__ = f"``ROOT/{name}``."

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> _File: ...
    @overload
    def __get__(self, obj: _Layout, owner: type | None = None) -> Path: ...
    def __get__(self, obj: _Layout | None, owner: type | None = None) -> Path | _File:
        return self if obj is None else obj.root / self.name


@dataclass(frozen=True)
class _Layout:
    root: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "root", Path(self.root))


@dataclass(frozen=True)
class RunLayout(_Layout):
    """The paths of one reprocess run folder.

    Args:
        root: The run folder (``slt reprocess --out``).
    """

    frames = _File(FRAMES_FILE)
    lanes = _File(LANES_FILE)
    corridor = _File(CORRIDOR_FILE)
    baseline = _File(BASELINE_FILE)
    can_signals = _File(CAN_SIGNALS_FILE)
    mobileye = _File(MOBILEYE_FILE)
    rtk = _File(RTK_FILE)
    curvature = _File(CURVATURE_FILE)
    curvature_summary = _File(CURVATURE_SUMMARY_FILE)
    availability_frames = _File(AVAILABILITY_FRAMES_FILE)
    availability_sequences = _File(AVAILABILITY_SEQUENCES_FILE)
    annotations = _File(ANNOTATIONS_FILE)
    overlay = _File(OVERLAY_FILE)
    report = _File(REPORT_FILE)
    report_html = _File(REPORT_HTML_FILE)
    plots = _File(PLOTS_DIR)
    manifest = _File(MANIFEST_FILE)

    def table(self, name: str) -> Path:
        """Return the path of a table by name (:data:`STREAMED_TABLES`, :data:`DERIVED_TABLES`).

        Raises:
            KeyError: For a name that is not a table of a run.
        """
        if name not in STREAMED_TABLES and name not in DERIVED_TABLES:
            raise KeyError(f"not a table of a reprocess run: {name!r}")
        path: Path = getattr(self, name)
        return path

    def streamed(self) -> dict[str, Path]:
        """Return table -> path of the tables written while the frames stream."""
        return {name: self.table(name) for name in STREAMED_TABLES}

    def derived(self) -> dict[str, Path]:
        """Return table -> path of the tables derived after the pass."""
        return {name: self.table(name) for name in DERIVED_TABLES}


@dataclass(frozen=True)
class ExtractLayout(_Layout):
    """The paths of one ``slt extract`` output folder (images go under ``frames/<topic>/``)."""

    frames = _File(FRAMES_FILE)
    camera_info = _File(CAMERA_INFO_FILE)
    can_raw = _File(CAN_RAW_FILE)
    can_signals = _File(CAN_SIGNALS_FILE)
    rtk = _File(RTK_FILE)


@dataclass(frozen=True)
class SummaryLayout(_Layout):
    """The paths of ``slt batch``'s fleet summary folder (``ROOT/summary``)."""

    fleet_status = _File(FLEET_STATUS_FILE)
    availability_by_category = _File(AVAILABILITY_BY_CATEGORY_FILE)
    curvature_by_recording = _File(CURVATURE_BY_RECORDING_FILE)
    report = _File(REPORT_FILE)
    comparison = _File(NIGHTLY_COMPARE_DIR)
    mined = _File(NIGHTLY_MINED_DIR)


# ---- slt compare and slt mine -------------------------------------------------------------
COMPARE_FILE = "compare.parquet"
"""``slt compare``: one row per sequence, drive, category and the fleet for every KPI."""
COMPARE_SPANS_FILE = "compare_spans.parquet"
COMPARE_DRIVES_FILE = "compare_drives.parquet"
COMPARE_REPORT_FILE = "compare.md"
"""The comparison report; ``compare.html`` is written beside it."""
COMPARE_DELTAS_PLOT = "deltas.png"
MINE_MANIFEST_FILE = "manifest.parquet"
MINE_IMAGES_DIR = "images"
TUSIMPLE_LABELS_FILE = "labels.json"
"""A TuSimple label folder's label lines (``slt mine`` writes it, ``slt train`` reads it)."""


@dataclass(frozen=True)
class CompareLayout(_Layout):
    """The paths of one ``slt compare`` output folder."""

    table = _File(COMPARE_FILE)
    spans = _File(COMPARE_SPANS_FILE)
    drives = _File(COMPARE_DRIVES_FILE)
    report = _File(COMPARE_REPORT_FILE)
    plots = _File(PLOTS_DIR)

    def deltas_plot(self) -> Path:
        """Return the path of the per-drive delta plot."""
        return self.plots / COMPARE_DELTAS_PLOT

    def timeline_plot(self, k: int) -> Path:
        """Return the path of the ``k``-th worst drive's availability timelines."""
        return self.plots / f"timeline_{k}.png"


@dataclass(frozen=True)
class MineLayout(_Layout):
    """The paths of one ``slt mine`` label set."""

    manifest = _File(MINE_MANIFEST_FILE)
    labels = _File(TUSIMPLE_LABELS_FILE)
    images = _File(MINE_IMAGES_DIR)


def example_plot_name(frame_index: int) -> str:
    """Return the file name (under :data:`PLOTS_DIR`) of a frame's example plot."""
    return f"example_{frame_index:06d}.png"


def is_reprocess_run(folder: str | os.PathLike[str]) -> bool:
    """Return whether ``folder`` is a complete reprocess run (by its files; sizes unchecked).

    A complete run holds :data:`MANIFEST_FILE` (written last), the availability tables and the
    report; drives without a camera have no streamed tables, so those are not required. Use
    :func:`~superlane_tools.reporting.run_folder.require_complete_run` to also check sizes.
    """
    layout = RunLayout(Path(folder))
    needed = (layout.manifest, layout.availability_sequences, layout.report)
    return layout.root.is_dir() and all(p.is_file() for p in needed)


# ---- schemas ------------------------------------------------------------------------------
STAGES = (
    "decode",
    "segmentation",
    "points",
    "corridor_net",
    "hough",
    "lane_fit",
    "corridor_geometry",
)
"""Per-frame stages whose wall and CPU times ``frames.parquet`` records (``<stage>_ms``)."""

FRAMES_SCHEMA = pa.schema(
    [
        ("frame_index", pa.int32()),
        ("log_time_ns", pa.int64()),
        ("stamp_ns", pa.int64()),
        ("width", pa.int32()),
        ("height", pa.int32()),
        ("process_width", pa.int32()),
        ("process_height", pa.int32()),
        ("ok", pa.bool_()),
        ("error", pa.string()),
        *[(f"{s}_ms", pa.float64()) for s in STAGES],
        *[(f"{s}_cpu_ms", pa.float64()) for s in STAGES],
    ]
)
"""``frames.parquet`` of a reprocess run: one row per camera frame, its sizes and stage times."""
LANES_SCHEMA = pa.schema([("frame_index", pa.int32()), ("log_time_ns", pa.int64()), *FIT_COLUMNS])
"""``lanes.parquet`` of a reprocess run: the frame, then the lane fit's columns (the road's
vertical curvature term ``c`` last: 1/m, ``z = b x + c x^2``; NaN without a fit)."""
LANES_FIT_SCHEMA = pa.schema([*FIT_COLUMNS, ("seg_time_ms", pa.float64())])
"""``slt lanes fit``'s table: the lane fit's columns plus the mask's segmentation time (ms, NaN
when unknown)."""
CORRIDOR_SCHEMA = pa.schema(
    [
        ("frame_index", pa.int32()),
        ("log_time_ns", pa.int64()),
        ("width_m", pa.float64()),
        ("length_m", pa.float64()),
        ("n_rows", pa.int32()),
        ("mean_frames", pa.int32()),
        ("status", pa.string()),
    ]
)
"""``corridor.parquet``: the corridor network's geometry per frame."""
BASELINE_SCHEMA = pa.schema(
    [
        ("frame_index", pa.int32()),
        ("log_time_ns", pa.int64()),
        ("ok", pa.bool_()),
        ("width_m", pa.float64()),
        ("range_m", pa.float64()),
        ("reason", pa.string()),
        ("left_line_px", pa.list_(pa.float64())),
        ("right_line_px", pa.list_(pa.float64())),
    ]
)
"""``baseline.parquet``: the Hough ego-lane baseline per frame."""
STREAMED_SCHEMAS = {
    "frames": FRAMES_SCHEMA,
    "lanes": LANES_SCHEMA,
    "corridor": CORRIDOR_SCHEMA,
    "baseline": BASELINE_SCHEMA,
}
"""Schema of each table in :data:`STREAMED_TABLES`."""

CAN_RAW_SCHEMA = pa.schema(
    [
        ("log_time_ns", pa.int64()),
        ("stamp_ns", pa.int64()),
        ("topic", pa.string()),
        ("can_id", pa.uint32()),
        ("is_extended", pa.bool_()),
        ("dlc", pa.int16()),
        ("data", pa.binary()),
    ]
)
"""``can_raw.parquet`` of ``slt extract``: one row per CAN frame."""
CAN_SIGNALS_SCHEMA = pa.schema(
    [
        ("log_time_ns", pa.int64()),
        ("can_id", pa.uint32()),
        ("message", pa.string()),
        ("signal", pa.string()),
        ("value", pa.float64()),
        ("unit", pa.string()),
        ("label", pa.string()),
        ("bus", pa.string()),
        ("dbc", pa.string()),
    ]
)
"""``can_signals.parquet`` of ``slt extract``: one row per decoded signal value."""
RTK_SCHEMA = pa.schema(
    [
        ("topic", pa.string()),
        ("log_time_ns", pa.int64()),
        ("stamp_ns", pa.int64()),
        ("latitude_deg", pa.float64()),
        ("longitude_deg", pa.float64()),
        ("altitude_m", pa.float64()),
        ("fix_status", pa.int8()),
        ("rtk_quality", pa.int16()),  # GGA quality: any 0-255 digit string is legal
        ("covariance_m2", pa.list_(pa.float64(), 9)),
        ("covariance_type", pa.int16()),  # NavSatFix uint8: 255 is legal
        ("east_m", pa.float64()),
        ("north_m", pa.float64()),
        ("up_m", pa.float64()),
        ("speed_mps", pa.float64()),
        ("heading_rad", pa.float64()),
    ]
)
"""``rtk.parquet`` of ``slt extract``: one row per GNSS fix with local ENU position."""
EXTRACT_FRAMES_SCHEMA = pa.schema(
    [
        ("topic", pa.string()),
        ("index", pa.int64()),
        ("log_time_ns", pa.int64()),
        ("stamp_ns", pa.int64()),
        ("width", pa.int32()),
        ("height", pa.int32()),
        ("encoding", pa.string()),
        ("path", pa.string()),
        ("ok", pa.bool_()),
        ("error", pa.string()),
    ]
)
"""``frames.parquet`` of ``slt extract``: one row per image written."""
CAMERA_INFO_SCHEMA = pa.schema(
    [
        ("topic", pa.string()),
        ("log_time_ns", pa.int64()),
        ("frame_id", pa.string()),
        ("width", pa.int32()),
        ("height", pa.int32()),
        ("distortion_model", pa.string()),
        ("d", pa.list_(pa.float64())),
        ("k", pa.list_(pa.float64())),
        ("r", pa.list_(pa.float64())),
        ("p", pa.list_(pa.float64())),
    ]
)
"""``camera_info.parquet`` of ``slt extract``: one row per CameraInfo message."""
