"""Evaluation metrics: TuSimple lanes, KITTI road ego lane, curvature errors."""

from superlane_tools.evaluation.curvature import CurvatureErrors, curvature_errors
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.kitti import (
    KittiGroundTruth,
    MaskScore,
    decode_ground_truth,
    lane_area_mask,
    score_mask,
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

__all__ = [
    "MAX_RUN_TIME_MS",
    "PIXEL_THRESH_PX",
    "POINT_ACC_THRESH",
    "CurvatureErrors",
    "EvaluationError",
    "FrameScore",
    "KittiGroundTruth",
    "MaskScore",
    "TuSimpleRecord",
    "TuSimpleScore",
    "bench",
    "curvature_errors",
    "decode_ground_truth",
    "evaluate",
    "evaluate_frames",
    "f1_from_rates",
    "format_record",
    "lane_angle",
    "lane_area_mask",
    "line_accuracy",
    "load_jsonl",
    "parse_record",
    "score_mask",
]
