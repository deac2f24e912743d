"""Evaluation metrics: the official TuSimple lane benchmark."""

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
    "EvaluationError",
    "FrameScore",
    "TuSimpleRecord",
    "TuSimpleScore",
    "bench",
    "evaluate",
    "evaluate_frames",
    "f1_from_rates",
    "format_record",
    "lane_angle",
    "line_accuracy",
    "load_jsonl",
    "parse_record",
]
