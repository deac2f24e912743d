"""Evaluation metrics: the official TuSimple lane benchmark and curvature errors."""

from superlane_tools.evaluation.curvature import CurvatureErrors, curvature_errors
from superlane_tools.evaluation.errors import EvaluationError
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
    "TuSimpleRecord",
    "TuSimpleScore",
    "bench",
    "curvature_errors",
    "evaluate",
    "evaluate_frames",
    "f1_from_rates",
    "format_record",
    "lane_angle",
    "line_accuracy",
    "load_jsonl",
    "parse_record",
]
