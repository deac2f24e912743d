"""Evaluation metrics: TuSimple (+ ego/3-lane modes, colour/style), KITTI BEV, CULane, Caltech."""

from superlane_tools.evaluation.caltech import CaltechScore, read_ccvl
from superlane_tools.evaluation.culane import (
    CulaneResult,
    CulaneScore,
    parse_lines_text,
    read_lines_file,
)
from superlane_tools.evaluation.curvature import CurvatureErrors, curvature_errors
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.kitti import (
    KittiGroundTruth,
    MaskScore,
    decode_ground_truth,
    ego_lane_mask,
    lane_area_mask,
    score_mask,
)
from superlane_tools.evaluation.kitti_bev import BevGrid, BevScore, evaluate_bev
from superlane_tools.evaluation.lane_modes import (
    MODES,
    AttributeAccuracy,
    attribute_accuracy,
    evaluate_mode,
)
from superlane_tools.evaluation.tusimple import (
    MAX_RUN_TIME_MS,
    PIXEL_THRESH_PX,
    POINT_ACC_THRESH,
    FrameScore,
    TuSimpleRecord,
    TuSimpleScore,
    bench,
    evaluate,
    evaluate_frames,
    f1_from_rates,
    format_record,
    lane_angle,
    line_accuracy,
    load_jsonl,
    parse_record,
)
from superlane_tools.evaluation.tusimple_export import ExportOptions, FittedFrame, export_records

__all__ = [
    "MAX_RUN_TIME_MS",
    "MODES",
    "PIXEL_THRESH_PX",
    "POINT_ACC_THRESH",
    "AttributeAccuracy",
    "BevGrid",
    "BevScore",
    "CaltechScore",
    "CulaneResult",
    "CulaneScore",
    "CurvatureErrors",
    "EvaluationError",
    "ExportOptions",
    "FittedFrame",
    "FrameScore",
    "KittiGroundTruth",
    "MaskScore",
    "TuSimpleRecord",
    "TuSimpleScore",
    "attribute_accuracy",
    "bench",
    "curvature_errors",
    "decode_ground_truth",
    "ego_lane_mask",
    "evaluate",
    "evaluate_bev",
    "evaluate_frames",
    "evaluate_mode",
    "export_records",
    "f1_from_rates",
    "format_record",
    "lane_angle",
    "lane_area_mask",
    "line_accuracy",
    "load_jsonl",
    "parse_lines_text",
    "parse_record",
    "read_ccvl",
    "read_lines_file",
    "score_mask",
]
