"""ROS 1 bags: their magic number and file suffix."""

from __future__ import annotations

from superlane_tools.recording.formats.probe import Probe, certain

MAGIC = b"#ROSBAG V2.0\n"
"""The version line every ROS 1 bag (format 2.0) starts with."""
VERSION = MAGIC.rstrip(b"\n")
"""The version line without its newline: a file starting so is recognised as a ROS 1 bag."""
SUFFIX = ".bag"
LABEL = "ROS 1 bag"


def recognise(probe: Probe) -> int:
    """Return the plug-in score of ``probe`` (certain when it starts with the bag magic)."""
    return certain(probe.head.startswith(VERSION))
