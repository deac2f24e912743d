"""``slt extract``: stream a recording into frames, CAN tables and a GNSS/RTK table."""

from superlane_tools.commands.extract.config import (
    FRAME_FORMATS,
    ExtractConfig,
    ExtractResult,
)
from superlane_tools.commands.extract.run import extract
from superlane_tools.recording import STREAM_KINDS, load_stream_config, select_streams

__all__ = [
    "FRAME_FORMATS",
    "STREAM_KINDS",
    "ExtractConfig",
    "ExtractResult",
    "extract",
    "load_stream_config",
    "select_streams",
]
