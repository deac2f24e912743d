"""``slt lanes``: the SUPER multi-lane fit over mask folders and its TuSimple/KITTI exports."""

from superlane_tools.commands.lanes.export import (
    ExportResult,
    export_kitti_ego_lane,
    export_tusimple,
    parse_h_samples,
)
from superlane_tools.commands.lanes.fit import LanesFitResult, fit_masks
from superlane_tools.lanes.class_map import ClassMap, load_classes, mask_points, parse_classes
from superlane_tools.lanes.table import lanes_from_row
from superlane_tools.scene.label_folder import find_masks, natural_key, read_segment_times

__all__ = [
    "ClassMap",
    "ExportResult",
    "LanesFitResult",
    "export_kitti_ego_lane",
    "export_tusimple",
    "find_masks",
    "fit_masks",
    "lanes_from_row",
    "load_classes",
    "mask_points",
    "natural_key",
    "parse_classes",
    "parse_h_samples",
    "read_segment_times",
]
