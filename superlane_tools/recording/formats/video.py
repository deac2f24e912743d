"""Video files: container suffixes and the first bytes of MP4/MOV, Matroska/WebM and AVI."""

from __future__ import annotations

from superlane_tools.recording.formats.probe import CERTAIN, Probe, certain

SUFFIXES = frozenset({".mp4", ".mkv", ".mov", ".avi", ".webm", ".m4v"})
"""Container suffixes opened as a video recording (raw ``.h264`` streams: ``slt convert``)."""
RAW_SUFFIXES = frozenset({".h264", ".h265"})
"""Raw video streams: only ``slt convert`` reads them."""
MP4_BOXES = (b"moov", b"mdat", b"free", b"wide", b"skip")
"""First boxes of MP4/MOV files that do not start with ``ftyp``."""
MATROSKA_MAGIC = b"\x1a\x45\xdf\xa3"
RIFF_MAGIC = b"RIFF"
FTYP = b"ftyp"
"""The box type at bytes 4-8 of an MP4/MOV file."""
MAGIC = (MATROSKA_MAGIC, RIFF_MAGIC)
"""What Matroska/WebM and AVI files start with (MP4/MOV: :data:`FTYP` at byte 4)."""
LABEL = "video file"


def looks_like_video(head: bytes) -> bool:
    """Return True when a file's first bytes are an MP4/MOV, Matroska/WebM or AVI header."""
    return (
        head[4:8] == FTYP
        or head.startswith(MATROSKA_MAGIC)
        or (head.startswith(RIFF_MAGIC) and head[8:12] == b"AVI ")
    )


def recognise(probe: Probe) -> int:
    """Return the plug-in score: certain for a video header, or an MP4 box under a video name."""
    if probe.is_dir:
        return 0
    if looks_like_video(probe.head):
        return CERTAIN
    # an MP4 may start with another box than ftyp
    return certain(probe.suffix in SUFFIXES and probe.head[4:8] in MP4_BOXES)
