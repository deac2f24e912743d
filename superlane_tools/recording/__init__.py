"""Recordings: open MCAP, ROS 1 and ROS 2 bags (and CAN / NMEA logs), stream, summarize, write."""

from superlane_tools.recording.base import Recording, SupportsStampPeek
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.summary import RecordingSummary, TopicSummary, summarize
from superlane_tools.recording.typestore import default_typestore
from superlane_tools.recording.writers import (
    RecordingWriter,
    WriterFormat,
    open_writer,
    write_protobuf_mcap,
)

__all__ = [
    "Recording",
    "RecordingError",
    "RecordingSummary",
    "RecordingWriter",
    "SupportsStampPeek",
    "TopicSummary",
    "WriterFormat",
    "default_typestore",
    "open_recording",
    "open_writer",
    "summarize",
    "write_protobuf_mcap",
]
