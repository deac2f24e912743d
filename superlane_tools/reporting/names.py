"""One name per method and curvature source, shared by the report, the plots and ``slt tables``."""

from __future__ import annotations

CURVATURE_NAMES: dict[str, str] = {
    "rtk": "Truth (RTK path curvature)",
    "super": "SUPER raw (2*a2, road ahead)",
    "super_road": "SUPER tracked road",
    "super_path": "SUPER tracked path",
    "super_road_sg": "SUPER untracked road",
    "super_path_sg": "SUPER untracked path",
    "mobileye": "Mobileye raw (2*C2)",
    "mobileye_path": "Mobileye path (same treatment as SUPER)",
    "dynamics": "Yaw rate / speed",
}
"""Curvature source (``<source>_curvature`` column) -> display name."""

AVAILABILITY_NAMES: dict[str, str] = {
    "super": "SUPER",
    "corridor_net": "Corridor net",
    "hough": "Hough",
    "mobileye": "Mobileye",
}
"""Availability method -> display name."""


def curvature_name(source: str) -> str:
    """Return the display name of a curvature source (the source itself when unknown)."""
    return CURVATURE_NAMES.get(source, source)


METHOD_NOT_RUN = "method unavailable"
"""Start of ``availability_frames.reason`` for every frame of a method that did not run."""

UNCATEGORISED = "uncategorised"
"""Category of a recording or sequence that states none (no ``--category``, manifest entry)."""
