"""The Arrow schema of every output table (each table's :class:`~.tables.TableSpec` names it).

Tables written row by row with a fixed type have a ``pa.Schema``; tables built as a whole (the
derived tables, and the tables of compare, mine and batch) have a :class:`DerivedSchema`: the
columns always there and those only some outputs have, checked by :func:`.checks.checked_table`.
The lane fit's columns come from :data:`superlane_tools.lanes.table.FIT_COLUMNS`.
"""

from __future__ import annotations

from dataclasses import dataclass

import pyarrow as pa

from superlane_tools.lanes.table import FIT_COLUMNS
from superlane_tools.lanes.tracker import COV_KEYS

# ---- the streamed tables of a reprocess run, and slt extract's tables -------------------------
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

# ---- the tables derived after the pass ------------------------------------------------------
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


# ---- slt compare, slt mine, slt batch and the simulator's training sets ---------------------
_I64 = pa.int64()
_BOOL = pa.bool_()

COMPARE_SCHEMA = DerivedSchema(
    pa.schema(
        [
            *[(name, _STR) for name in ("scope", "drive")],
            ("sequence", _I64),
            ("category", _STR),
            ("start_ns", _I64),
            *[(name, _STR) for name in ("kpi", "label", "unit")],
            ("higher_is_better", _BOOL),
            *_floats("base", "candidate", "delta", "ci_low", "ci_high"),
            ("n_sequences", _I64),
            ("n_drives", _I64),
            ("paired", _BOOL),
            *_floats("p_value", "margin"),
            ("note", _STR),
            ("verdict", _STR),
        ]
    )
)
"""``compare.parquet``: one row per scope (fleet, category, drive, sequence) and KPI; the
columns after ``higher_is_better`` are :class:`superlane_tools.fleet.bootstrap.Delta`'s."""
COMPARE_SPANS_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("drive", _STR),
            ("start_ns", _I64),
            ("stop_ns", _I64),
            *_floats("start_s", "duration_s"),
            ("first_frame", _I64),
            ("last_frame", _I64),
            *_floats("score", "peak_score"),
            ("main_difference", _STR),
            *[(name, _STR) for name in ("recording", "base_annotations", "candidate_annotations")],
        ]
    ),
    pa.schema([("content_hash", _STR)]),
)
"""``compare_spans.parquet`` (what ``slt mine --compare`` reads): the worst disagreement spans
of the matched drives, with the recording and both runs' annotation paths; ``content_hash``
where the writer knows it (``slt mine`` reads it from the runs' provenance otherwise). No
columns when no drive matched."""
COMPARE_DRIVES_SCHEMA = DerivedSchema(
    pa.schema(
        [
            (name, _STR)
            for name in (
                "drive",
                "status",
                "recording",
                "category",
                "base_folder",
                "candidate_folder",
            )
        ]
    )
)
"""``compare_drives.parquet``: one row per drive, matched or why not."""
MINE_CRITERIA = (
    "disagree",
    "availability_drop",
    "fit_quality",
    "lane_change",
    "curvature_extreme",
    "span",
    "low_light",
)
"""The criteria of ``slt mine``: a manifest has a score column for each criterion it used."""
MINE_MANIFEST_SCHEMA = DerivedSchema(
    pa.schema(
        [
            *[(name, _STR) for name in ("drive", "recording", "image")],
            ("frame_index", _I64),
            ("log_time_ns", _I64),
            ("width", _I64),
            ("height", _I64),
            ("reasons", _STR),
            ("score", _F64),
        ]
    ),
    pa.schema(_floats(*MINE_CRITERIA)),
)
"""``manifest.parquet`` of ``slt mine``: one row per picked frame (no columns without one)."""
CORRIDOR_MASKS_SCHEMA = DerivedSchema(
    pa.schema([("name", _STR), *_floats("corridor_fraction", "width_m", "length_m")])
)
"""``corridor.parquet`` of ``slt corridor``: one row per image (its mask's path under the output
folder), the corridor's share of the image and its geometry (NaN without a camera)."""
FLEET_STATUS_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("category", _STR),
            *[(name, _I64) for name in ("recordings", "ok", "partial", "failed", "frames")],
            ("processing_s", _F64),
        ]
    )
)
"""``summary/fleet_status.parquet`` of ``slt batch``: recordings per category and outcome."""
AVAILABILITY_BY_CATEGORY_SCHEMA = DerivedSchema(
    pa.schema(
        [
            ("category", _STR),
            ("method", _STR),
            *[(name, _I64) for name in ("recordings", "sequences", "n", "N")],
            ("frame_ratio", _F64),
            ("k", _I64),
            ("K", _I64),
            ("sequence_ratio", _F64),
            ("method_available", _BOOL),
        ]
    )
)
"""``summary/availability_by_category.parquet``: available frames ``n`` of ``N`` and sequences
``k`` of ``K`` per category and method (corridor paper Table II)."""
CURVATURE_BY_RECORDING_SCHEMA = DerivedSchema(
    pa.schema(
        [
            *[(name, _STR) for name in ("recording_id", "category", "source")],
            ("n", _I64),
            *_floats("coverage", "rmse", "mae", "bias", "correlation"),
        ]
    )
)
"""``summary/curvature_by_recording.parquet``: each estimate's errors (1/m) against RTK, per
finished recording."""
HISTORY_DRIFTS_SCHEMA = DerivedSchema(
    pa.schema(
        [
            *[(name, _STR) for name in ("kpi", "rule", "first_night", "last_night")],
            ("nights", _I64),
            *_floats("first_value", "last_value", "change", "margin"),
            ("caught_by", _STR),
            ("caught", _BOOL),
        ]
    )
)
"""``history_drifts.parquet`` of ``slt history``: one row per drift alarm of a KPI over the
nights (no columns without one), and the nights whose gate caught it."""
BATCH_STATUS_SCHEMA = pa.schema(
    [
        *[(name, _STR) for name in ("recording_id", "recording", "category", "vehicle")],
        *[(name, _STR) for name in ("date", "sequence")],
        *_floats("start_s", "end_s"),
        ("content_hash", _STR),
        ("size_bytes", _I64),
        ("mtime_ns", _I64),
        *[(name, _STR) for name in ("status", "result", "error")],
        ("attempts", _I64),
        ("total_s", _F64),
        ("timings_json", _STR),
        ("outputs", _I64),
        ("frames", _I64),
        *[(name, _STR) for name in ("job", "tool_version", "models_json", "config_sha256")],
        *[(name, _STR) for name in ("key", "engine", "host", "ray_node")],
        ("finished_ns", _I64),
    ]
)
"""``batch_status.parquet``: one row per recording. ``status`` is what this run did (``ok``,
``partial``, ``failed`` or ``skipped``); ``result`` is the state of the outputs on disk (``ok``,
``partial`` or ``failed``), so a ``skipped`` row still tells whether its earlier run was ok or
partial. ``timings_json`` maps stage -> seconds; ``models_json`` maps model or data file ->
SHA-256. ``host`` is the worker's host name and ``ray_node`` its Ray node id (``""`` on the
local engine, for skipped rows, and when a Ray worker died before it could tell)."""
"""Length of each sampled world, seconds of driving."""

DATASET_INDEX_SCHEMA = pa.schema(
    [
        ("sample", pa.int32()),
        ("image", pa.string()),
        ("labels", pa.string()),
        ("corridor", pa.string()),
        ("scenario", pa.string()),
        ("world_seed", pa.int64()),
        ("t_s", pa.float64()),
        ("fx", pa.float64()),
        ("fy", pa.float64()),
        ("cx", pa.float64()),
        ("cy", pa.float64()),
        ("camera_height_m", pa.float64()),
        ("pitch_rad", pa.float64()),
        ("roll_rad", pa.float64()),
        ("yaw_rad", pa.float64()),
        ("line_offset_m", pa.list_(pa.float64())),
        ("line_color", pa.list_(pa.string())),
        ("line_style", pa.list_(pa.string())),
        ("lane_heading_rad", pa.float64()),
        ("lane_curvature", pa.float64()),
        ("road_slope", pa.float64()),
        ("ego_left_line", pa.int32()),
        ("ego_right_line", pa.int32()),
        ("h_samples", pa.list_(pa.int32())),
        ("tusimple_lanes", pa.list_(pa.list_(pa.int32()))),
    ]
)
"""``index.parquet`` of ``slt simulate dataset``: one row per sample (image, labels and corridor
are paths relative to the folder)."""
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
