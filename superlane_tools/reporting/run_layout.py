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
the ``*_SCHEMA`` constants for the Arrow schema of every streamed table, and
:data:`DERIVED_SCHEMAS` (checked by :func:`checked_table` when reprocess writes them) for the
tables derived after the pass. ``slt extract``'s folder
(:class:`ExtractLayout`) and the batch summary (:class:`SummaryLayout`) are named here too, so
that ``slt tables``, ``slt batch``, ``slt compare`` and ``slt mine`` read what reprocess wrote
by the same names. The lanes columns come from :data:`superlane_tools.lanes.table.FIT_COLUMNS`
(the lane layer builds the rows); every other schema is defined in this module.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, overload

import pyarrow as pa

from superlane_tools.lanes.table import FIT_COLUMNS
from superlane_tools.lanes.tracker import COV_KEYS

if TYPE_CHECKING:
    import pandas as pd

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


# ---- the fleet's history (pipelines/nightly.py appends, slt history reads) ---------------------
HISTORY_DIR = "history"
"""The partitioned Parquet dataset of nightly KPIs under a nightly root (``night=DATE/``)."""
HISTORY_REPORT_FILE = "history.md"
"""``slt history``'s page; ``history.html`` is written beside it."""
HISTORY_DRIFTS_FILE = "history_drifts.parquet"
HISTORY_PARTITION = "night"
"""The dataset's hive partition key: the night, ``YYYY-MM-DD``."""


@dataclass(frozen=True)
class HistoryLayout(_Layout):
    """The fleet's history under a nightly root: the dataset and one night's partition."""

    dataset = _File(HISTORY_DIR)

    def partition(self, night: str) -> Path:
        """Return the folder of one night's files (``history/night=DATE``)."""
        return self.dataset / f"{HISTORY_PARTITION}={night}"


@dataclass(frozen=True)
class HistoryReportLayout(_Layout):
    """The paths of one ``slt history`` output folder."""

    report = _File(HISTORY_REPORT_FILE)
    drifts = _File(HISTORY_DRIFTS_FILE)
    plots = _File(PLOTS_DIR)

    def kpi_plot(self, kpi: str) -> Path:
        """Return the path of one KPI's plot over the nights."""
        return self.plots / f"history_{kpi.replace('.', '_')}.png"


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

# ---- schemas of the derived tables --------------------------------------------------------
_F64 = pa.float64()
_STR = pa.string()


def _floats(*names: str) -> list[tuple[str, pa.DataType]]:
    return [(name, _F64) for name in names]


_NO_COLUMNS = pa.schema([])


@dataclass(frozen=True)
class DerivedSchema:
    """The columns a derived table may hold: those always there, and those only some drives have.

    A table with rows holds every ``required`` column; an empty table (a drive without the
    input) may lack any. No table holds a column declared in neither. Strings may be Arrow
    ``string`` or ``large_string``, a categorical is compared by its values, and an all-missing
    column (Arrow ``null``) matches any type. Column order is the builder's.

    Attributes:
        required: Columns of every non-empty table.
        optional: Columns present only when the drive has what they describe.
    """

    required: pa.Schema
    optional: pa.Schema = _NO_COLUMNS

    def types(self) -> dict[str, pa.DataType]:
        """Return column -> declared Arrow type, required then optional."""
        return {f.name: f.type for f in (*self.required, *self.optional)}


class SchemaMismatchError(RuntimeError):
    """A derived table disagrees with its declared schema (an internal error).

    A builder or :data:`DERIVED_SCHEMAS` changed without the other.
    """


MOBILEYE_SIDES = ("left", "right")
"""The ego lines of ``mobileye.parquet``: each ``<side>_*`` column exists for both sides."""
MOBILEYE_SIDE_COLUMNS = (
    "a0_m",
    "a1_rad",
    "a2_per_m",
    "a3_per_m2",
    "quality",
    "view_range_m",
    "curvature",
)
"""``<side>_<column>`` of ``mobileye.parquet`` (``y = a0 + a1 x + a2 x^2 + a3 x^3``, y left)."""
MOBILEYE_SCHEMA = DerivedSchema(
    pa.schema([("log_time_ns", pa.int64())]),
    pa.schema(
        [
            *_floats(*(f"{s}_{c}" for s in MOBILEYE_SIDES for c in MOBILEYE_SIDE_COLUMNS)),
            *_floats("curvature", "corridor_width_m", "corridor_length_m", "lane_curvature"),
        ]
    ),
)
"""``mobileye.parquet``: one row per Mobileye lane update (only ``log_time_ns`` without any,
the side columns of the sides present)."""
RTK_TRUTH_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("log_time_ns", pa.int64()),
            ("topic", _STR),
            *_floats("latitude_deg", "longitude_deg", "altitude_m"),
            ("fix_status", pa.int8()),
            *_floats("east_m", "north_m", "up_m"),
            ("good", pa.bool_()),
            ("flag", _STR),
            ("gap_before_s", _F64),
            ("dropout_before", pa.bool_()),
            *_floats("s_m", "heading_rad", "curvature_per_m"),
            ("curvature_valid", pa.bool_()),
            ("speed_mps", _F64),
            ("slow", pa.bool_()),
        ]
    )
)
"""``rtk.parquet`` of a reprocess run: one row per GNSS fix, flagged, with the truth's path."""
CURVATURE_SOURCE_COLUMNS = (
    "super_curvature",
    "super_road_curvature",
    "super_path_curvature",
    "super_road_sg_curvature",
    "super_path_sg_curvature",
    "mobileye_curvature",
    "mobileye_path_curvature",
    "dynamics_curvature",
)
"""``<source>_curvature`` of ``curvature.parquet``: the estimates compared with RTK (the
sources of :data:`superlane_tools.reporting.drive_tables.CURVATURE_SOURCES`), 1/m, left positive."""
CURVATURE_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("frame_index", pa.int32()),
            ("log_time_ns", pa.int64()),
            *_floats("t_s", "s_m", "speed_mps", "yaw_rate_rps", "rtk_curvature"),
            ("rtk_valid", pa.bool_()),
            *_floats(*CURVATURE_SOURCE_COLUMNS),
            *_floats("super_lookahead_m", "super_lateral_m", "super_lateral_sg_curvature"),
            *_floats("super_lateral_curvature", "super_travelled_m"),
            *_floats("super_fit_a1", "super_fit_b", "super_fit_near_m", "super_fit_far_m"),
            *_floats("super_fit_trackable", *COV_KEYS),
            *_floats("super_error", "super_path_error", "mobileye_error"),
        ]
    ),
    pa.schema(
        [
            ("super_heading_rad", _F64),
            ("super_track_used", pa.bool_()),
            ("super_track_gated", pa.bool_()),
            *_floats("super_track_road_curvature", "super_track_lateral_curvature"),
        ]
    ),
)
"""``curvature.parquet``: one row per frame, the truth and every estimate; the ``super_track*``
and ``super_heading_rad`` columns only where the lane tracker ran."""
CURVATURE_SUMMARY_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("scope", _STR),
            ("category", _STR),
            ("start", pa.int64()),
            ("stop", pa.int64()),
            ("source", _STR),
            ("n", pa.int64()),
            *_floats("coverage", "rmse", "mae", "bias", "correlation"),
            ("truth_noise_floor_per_m", _F64),
            ("truth_degraded", pa.bool_()),
            ("mobileye_latency_s", _F64),
            ("mobileye_latency_resolved", pa.bool_()),
        ]
    )
)
"""``curvature_summary.parquet``: errors per ``source`` (``<source>_curvature``) against RTK,
``scope`` ``overall`` then ``seq<k>``."""
AVAILABILITY_FRAMES_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("frame_index", pa.int32()),
            ("log_time_ns", pa.int64()),
            ("method", _STR),
            *_floats("width_m", "width_at_m", "length_m", "speed_mps", "required_length_m"),
            ("available", pa.bool_()),
            ("known", pa.bool_()),
            ("reason", _STR),
        ]
    )
)
"""``availability_frames.parquet``: one row per frame and method."""
AVAILABILITY_SEQUENCES_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("start", pa.int64()),
            ("stop", pa.int64()),
            ("category", _STR),
            ("n_frames", pa.int64()),
            ("n_available", pa.int64()),
            ("n_unknown", pa.int64()),
            ("ratio", _F64),
            ("available", pa.bool_()),
            ("longest_outage_frames", pa.int64()),
            ("longest_outage_s", _F64),
            ("method", _STR),
            ("sequence", pa.int64()),
            ("start_ns", pa.int64()),
            ("method_available", pa.bool_()),
            *_floats("width_at_m", "median_width_m", "median_length_m"),
        ]
    )
)
"""``availability_sequences.parquet``: one row per sequence and method (no columns without
frames)."""
DERIVED_SCHEMAS = {
    "can_signals": DerivedSchema(CAN_SIGNALS_SCHEMA),
    "mobileye": MOBILEYE_SCHEMA,
    "rtk": RTK_TRUTH_SCHEMA,
    "curvature": CURVATURE_SCHEMA,
    "curvature_summary": CURVATURE_SUMMARY_SCHEMA,
    "availability_frames": AVAILABILITY_FRAMES_SCHEMA,
    "availability_sequences": AVAILABILITY_SEQUENCES_SCHEMA,
}
"""Schema of each table in :data:`DERIVED_TABLES`."""


def _base_type(t: pa.DataType) -> pa.DataType:
    if pa.types.is_dictionary(t):
        return _base_type(t.value_type)
    if pa.types.is_large_string(t):
        return pa.string()
    return t


def checked_table(name: str, table: pa.Table | pd.DataFrame) -> pa.Table:
    """Return a derived table as Arrow after checking it against :data:`DERIVED_SCHEMAS`.

    The table is returned as built (a DataFrame converted without its index, nothing cast), so
    the check never changes what is written.

    Raises:
        SchemaMismatchError: For an undeclared column, a missing required column (in a table
            with rows) or a column of another type.
    """
    if not isinstance(table, pa.Table):
        table = pa.Table.from_pandas(table, preserve_index=False)
    spec = DERIVED_SCHEMAS[name]
    declared = spec.types()
    problems = []
    undeclared = [c for c in table.column_names if c not in declared]
    if undeclared:
        problems.append(f"undeclared columns {undeclared}")
    missing = [f.name for f in spec.required if f.name not in table.column_names]
    if missing and table.num_rows:
        problems.append(f"missing columns {missing}")
    for field in table.schema:
        want = declared.get(field.name)
        got = _base_type(field.type)
        if want is not None and not pa.types.is_null(got) and got != _base_type(want):
            problems.append(f"{field.name} is {field.type}, declared {want}")
    if problems:
        raise SchemaMismatchError(f"{name}: {'; '.join(problems)}")
    return table


HISTORY_SCHEMA = pa.schema(
    [
        ("recorded_ns", pa.int64()),
        ("kind", pa.string()),
        ("root", pa.string()),
        ("baseline", pa.string()),
        ("model", pa.string()),
        ("model_id", pa.string()),
        ("config_id", pa.string()),
        ("tool_version", pa.string()),
        ("base_model", pa.string()),
        ("base_config_id", pa.string()),
        ("kpi", pa.string()),
        ("unit", pa.string()),
        ("higher_is_better", pa.bool_()),
        ("value", pa.float64()),
        ("base_value", pa.float64()),
        ("delta", pa.float64()),
        ("ci_low", pa.float64()),
        ("ci_high", pa.float64()),
        ("n_drives", pa.int64()),
        ("n_sequences", pa.int64()),
        ("verdict", pa.string()),
    ]
)
"""One file of the fleet's history (the night is the partition key, not a column of the file).

``kind``: ``fleet`` (the night's fleet summary: ``value`` is the fleet value, no interval) or
``compare`` (the night's comparison with its baseline: ``value`` is the candidate's, with the
base value, the delta, its interval and the verdict). Nulls where a value does not apply or
the comparison table lacks the column (``n_drives`` of older tables).
"""
