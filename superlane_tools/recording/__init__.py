"""Recordings: open MCAP, ROS 1/2 bags, CAN/NMEA logs; stream, decode video, convert, write."""

from superlane_tools.recording.align import align
from superlane_tools.recording.base import Recording, SkipLog, SupportsStampPeek, time_range_ns
from superlane_tools.recording.convert import ConvertConfig, ConvertInput, convert
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.images import decode_frame, decode_reduced
from superlane_tools.recording.open import (
    READERS,
    ReaderPlugin,
    fast_info,
    find_reader,
    open_recording,
)
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
from superlane_tools.recording.streams import (
    FRAME_TYPES,
    STREAM_KINDS,
    Streams,
    check_topic_kinds,
    load_stream_config,
    message_total,
    select_one_each,
    select_streams,
    topics_of_type,
)
from superlane_tools.recording.summary import RecordingSummary, TopicSummary, summarize
from superlane_tools.recording.times import TimeSpec, format_utc, parse_time
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
    "FRAME_TYPES",
    "READERS",
    "STREAM_KINDS",
    "ConvertConfig",
    "ConvertInput",
    "Loss",
    "ReaderPlugin",
    "Recording",
    "RecordingError",
    "RecordingScan",
    "RecordingSummary",
    "RecordingWriter",
    "ScanChannel",
    "ScanSchema",
    "ScannedMessage",
    "SkipLog",
    "Streams",
    "SupportsStampPeek",
    "TimeSpec",
    "TopicLoss",
    "TopicSummary",
    "VideoDecoder",
    "VideoEncoder",
    "WriterFormat",
    "align",
    "check_topic_kinds",
    "convert",
    "decode_frame",
    "decode_reduced",
    "decode_video",
    "default_typestore",
    "fast_info",
    "find_reader",
    "format_utc",
    "load_stream_config",
    "message_total",
    "open_recording",
    "open_writer",
    "parse_time",
    "read_with_video",
    "scan_mcap",
    "scan_recording",
    "scan_ros1",
    "select_one_each",
    "select_streams",
    "summarize",
    "time_range_ns",
    "topics_of_type",
    "write_protobuf_mcap",
]
