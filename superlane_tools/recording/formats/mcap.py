"""MCAP: its magic number and file suffix."""

from __future__ import annotations

from superlane_tools.recording.formats.probe import Probe, certain

MAGIC = b"\x89MCAP0\r\n"
"""The 8 bytes every MCAP file starts (and, when complete, ends) with."""
FAMILY = MAGIC[:5]
"""The magic without its version: a file starting so is recognised as MCAP."""
SUFFIX = ".mcap"
LABEL = "MCAP file"


def recognise(probe: Probe) -> int:
    """Return the plug-in score of ``probe`` (certain when it starts with the MCAP magic)."""
    return certain(probe.head.startswith(FAMILY))
