"""Ego-corridor geometry in metres, the Hough ego-lane baseline, and availability KPIs."""

from superlane_tools.corridor.availability import (
    AvailabilityParams,
    FrameAvailability,
    Segment,
    SequenceAvailability,
    TimeSegment,
    frame_availability,
    longest_run,
    segments_at_times,
    sequence_availability,
    windows,
)
from superlane_tools.corridor.errors import CorridorError
from superlane_tools.corridor.geometry import (
    CorridorGeometry,
    CorridorParams,
    corridor_from_lanes,
    corridor_from_mask,
    measurable_range_m,
    width_distance,
)
from superlane_tools.corridor.hough import (
    HoughParams,
    HoughResult,
    HoughTracker,
    LineSegment,
    detect_ego_lane,
    edges_and_segments,
)

__all__ = [
    "AvailabilityParams",
    "CorridorError",
    "CorridorGeometry",
    "CorridorParams",
    "FrameAvailability",
    "HoughParams",
    "HoughResult",
    "HoughTracker",
    "LineSegment",
    "Segment",
    "SequenceAvailability",
    "TimeSegment",
    "corridor_from_lanes",
    "corridor_from_mask",
    "detect_ego_lane",
    "edges_and_segments",
    "frame_availability",
    "longest_run",
    "measurable_range_m",
    "segments_at_times",
    "sequence_availability",
    "width_distance",
    "windows",
]
