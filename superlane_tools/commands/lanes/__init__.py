"""``slt lanes``: the SUPER multi-lane fit over mask folders and its TuSimple/KITTI exports."""

from superlane_tools.commands.lanes.export import export_kitti_ego_lane, export_tusimple
from superlane_tools.commands.lanes.fit import (
    SCHEMA,
    ClassMap,
    ExportResult,
    LanesFitResult,
    find_masks,
    fit_masks,
    lanes_from_row,
    load_classes,
    mask_points,
    natural_key,
    parse_classes,
    parse_h_samples,
    read_segment_times,
)

__all__ = [
    "SCHEMA",
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
