"""Recordings: open MCAP, ROS 1/2 bags, CAN/NMEA logs; stream, decode video, convert, write."""

from superlane_tools.recording.base import Recording, SupportsStampPeek
from superlane_tools.recording.convert import ConvertConfig, ConvertInput, convert
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.scan import (
    Loss,
    RecordingScan,
    ScanChannel,
    ScannedMessage,
    ScanSchema,
    TopicLoss,
    scan_mcap,
    scan_recording,
    scan_ros1,
)
from superlane_tools.recording.summary import RecordingSummary, TopicSummary, summarize
from superlane_tools.recording.times import TimeSpec, parse_time
from superlane_tools.recording.typestore import default_typestore
from superlane_tools.recording.video import (
    VideoDecoder,
    VideoEncoder,
    decode_video,
    read_with_video,
)
from superlane_tools.recording.writers import (
    RecordingWriter,
    WriterFormat,
    open_writer,
    write_protobuf_mcap,
)

__all__ = [
    "ConvertConfig",
    "ConvertInput",
    "Loss",
    "Recording",
    "RecordingError",
    "RecordingScan",
    "RecordingSummary",
    "RecordingWriter",
    "ScanChannel",
    "ScanSchema",
    "ScannedMessage",
    "SupportsStampPeek",
    "TimeSpec",
    "TopicLoss",
    "TopicSummary",
    "VideoDecoder",
    "VideoEncoder",
    "WriterFormat",
    "convert",
    "decode_video",
    "default_typestore",
    "open_recording",
    "open_writer",
    "parse_time",
    "read_with_video",
    "scan_mcap",
    "scan_recording",
    "scan_ros1",
    "summarize",
    "write_protobuf_mcap",
]
