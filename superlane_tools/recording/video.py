"""Compressed video in recordings (H.264, H.265, AV1, VP9), decoded with PyAV (FFmpeg).

A video stream is stateful: a frame can only be decoded after the keyframe it depends on, and
the decoder may hold frames back. :class:`VideoDecoder` is fed one message payload at a time,
in log-time order, and returns the frames (or the reason a payload gave none) as they come out.
:func:`decode_video` wraps a message stream, replacing each video message by a
:data:`DECODED_MSGTYPE` message that carries the BGR pixels; :func:`read_with_video` also seeks
back to the keyframe before a range's start, so ``--start`` works in the middle of a GOP.

Message types recognised: ``foxglove.CompressedVideo`` (protobuf), ``foxglove_msgs/msg/
CompressedVideo`` (ROS 2) and ``sensor_msgs/msg/CompressedImage`` whose ``format`` names a video
codec (``h264``, ``h265``/``hevc``, ``av1``, ``vp9``), as ``ffmpeg_image_transport`` users write.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.recording.base import Recording, field_value
from superlane_tools.recording.errors import RecordingError
from superlane_tools.records import Message

VIDEO_MSGTYPES = frozenset({"foxglove.CompressedVideo", "foxglove_msgs/msg/CompressedVideo"})
"""Message types that always carry compressed video."""

COMPRESSED_IMAGE_TYPES = frozenset({"sensor_msgs/msg/CompressedImage", "foxglove.CompressedImage"})
"""Image types whose ``format`` may name a video codec instead of an image format."""

DECODED_MSGTYPE = "slt/DecodedVideoFrame"
"""Message type of the messages :func:`decode_video` puts in place of video messages."""

FFMPEG_CODECS = {
    "h264": "h264",
    "avc": "h264",
    "h265": "hevc",
    "hevc": "hevc",
    "av1": "av1",
    "vp9": "vp9",
}
"""Video format names (as recordings spell them) -> FFmpeg decoder names."""

DECODER_PREFERENCE = {"av1": ("libdav1d", "libaom-av1", "av1")}
"""FFmpeg decoders to try per codec, in order (FFmpeg's own ``av1`` decodes only with hardware)."""

BEFORE_KEYFRAME = "before the first keyframe"
"""Skip reason of frames that precede the stream's first decodable keyframe."""

_SEEK_WINDOWS_S = (5.0, 30.0, 120.0)
_NS = 1_000_000_000


def video_codec(msgtype: str, fmt: str) -> str | None:
    """Return the FFmpeg decoder name for a message's type and format, or None if not video.

    Args:
        msgtype: Message type name in ROS 2 form (or the protobuf full name).
        fmt: The message's ``format`` field (``h264``, ``jpeg``, ``bgr8; h264``, ...).
    """
    if msgtype not in VIDEO_MSGTYPES and msgtype not in COMPRESSED_IMAGE_TYPES:
        return None
    for token in fmt.lower().replace(";", " ").replace(",", " ").split():
        codec = FFMPEG_CODECS.get(token.strip())
        if codec is not None:
            return codec
    if msgtype in VIDEO_MSGTYPES:
        return FFMPEG_CODECS["h264"] if not fmt else None
    return None


def message_codec(msg: Message) -> str | None:
    """Return the FFmpeg decoder name of a decoded message, or None when it is not video."""
    if msg.msgtype not in VIDEO_MSGTYPES and msg.msgtype not in COMPRESSED_IMAGE_TYPES:
        return None
    return video_codec(msg.msgtype, str(field_value(msg.data, "format") or ""))


def decoder_name(codec: str) -> str | None:
    """Return the installed FFmpeg decoder to use for ``codec`` (None: none installed)."""
    import av

    return next(
        (n for n in DECODER_PREFERENCE.get(codec, (codec,)) if n in av.codecs_available), None
    )


def decoder_available(codec: str) -> bool:
    """Return True when the installed FFmpeg can decode ``codec``."""
    return decoder_name(codec) is not None


def is_keyframe(codec: str, payload: bytes) -> bool:
    """Return True when ``payload`` (one access unit) is a keyframe, using FFmpeg's parser."""
    import av

    try:
        parser = av.CodecContext.create(codec, "r")
        packets = parser.parse(payload) + parser.parse(None)
    except (av.FFmpegError, ValueError):
        return False
    return any(p.is_keyframe for p in packets)


class VideoFrame(NamedTuple):
    """One payload's outcome: its pixels, or why it gave none.

    Attributes:
        log_time_ns: Log time of the payload's message, ns.
        stamp_ns: Its header stamp, ns (None when absent).
        image: Decoded BGR uint8 pixels, ``(height, width, 3)``; None when skipped.
        skipped: Why there is no image ("" when there is one).
    """

    log_time_ns: int
    stamp_ns: int | None
    image: NDArray[np.uint8] | None
    skipped: str = ""


@dataclass
class VideoDecoder:
    """A stateful decoder of one video stream; feed payloads in log-time order.

    Args:
        codec: FFmpeg decoder name (``h264``, ``hevc``, ``av1``, ``vp9``).
        threads: Decoder threads (0: FFmpeg's choice).

    Raises:
        RecordingError: If the installed FFmpeg has no such decoder.
    """

    codec: str
    threads: int = 0
    _ctx: Any = field(init=False, repr=False)
    _pending: dict[int, tuple[int, int | None]] = field(init=False, default_factory=dict)
    _next_pts: int = field(init=False, default=0)
    _started: bool = field(init=False, default=False)

    def __post_init__(self) -> None:
        import av

        name = decoder_name(self.codec)
        if name is None:
            raise RecordingError(f"this FFmpeg build has no {self.codec} decoder")
        self._ctx = av.CodecContext.create(name, "r")
        self._ctx.thread_count = self.threads
        self._ctx.thread_type = "SLICE"  # frame threading delays output by one frame per thread

    def feed(self, log_time_ns: int, stamp_ns: int | None, payload: bytes) -> list[VideoFrame]:
        """Decode one payload; return the outcomes that are ready (possibly of earlier ones).

        Payloads before the first keyframe are returned at once as skipped
        (:data:`BEFORE_KEYFRAME`); a payload the decoder rejects is returned as skipped with
        FFmpeg's reason.
        """
        import av

        if not payload:
            return [VideoFrame(log_time_ns, stamp_ns, None, "empty video payload")]
        if not self._started:
            if not is_keyframe(self.codec, payload):
                return [VideoFrame(log_time_ns, stamp_ns, None, BEFORE_KEYFRAME)]
            self._started = True
        packet = av.Packet(payload)
        packet.pts = self._next_pts
        self._pending[self._next_pts] = (log_time_ns, stamp_ns)
        self._next_pts += 1
        try:
            frames = self._ctx.decode(packet)
        except av.FFmpegError as err:
            self._pending.pop(packet.pts, None)
            reason = f"{self.codec} payload cannot be decoded: {err.strerror or err}"
            return [VideoFrame(log_time_ns, stamp_ns, None, reason)]
        return self._outcomes(frames)

    def flush(self) -> list[VideoFrame]:
        """Drain the decoder at the end of the stream; payloads that gave no frame are skipped."""
        import av

        try:
            out = self._outcomes(self._ctx.decode(None)) if self._started else []
        except av.FFmpegError:
            out = []
        out.extend(
            VideoFrame(t, s, None, f"{self.codec} payload gave no frame")
            for t, s in self._pending.values()
        )
        self._pending.clear()
        return out

    def _outcomes(self, frames: Iterable[Any]) -> list[VideoFrame]:
        out = []
        for frame in frames:
            times = self._pending.pop(frame.pts, None) if frame.pts is not None else None
            if times is None:  # no pts back: frames come out in feeding order
                if not self._pending:
                    continue
                times = self._pending.pop(min(self._pending))
            image: NDArray[np.uint8] = frame.to_ndarray(format="bgr24")
            out.append(VideoFrame(times[0], times[1], np.ascontiguousarray(image)))
        return out


class DecodedImage(NamedTuple):
    """Data of a :data:`DECODED_MSGTYPE` message.

    Attributes:
        image: BGR uint8 pixels, or None when the payload gave no frame.
        format: The video format as recorded (``h264``, ...).
        error: Why there is no image ("" when there is one).
    """

    image: NDArray[np.uint8] | None
    format: str
    error: str = ""


def decoded_image(msg: Message) -> NDArray[np.uint8]:
    """Return the pixels of a :data:`DECODED_MSGTYPE` message.

    Raises:
        ValueError: With the skip reason when the payload gave no frame.
    """
    data: DecodedImage = msg.data
    if data.image is None:
        raise ValueError(f"{data.format} frame skipped: {data.error}")
    return data.image


def decode_video(messages: Iterable[Message], start_ns: int | None = None) -> Iterator[Message]:
    """Replace video messages by decoded :data:`DECODED_MSGTYPE` messages; pass others on.

    A decoded frame is yielded when the decoder gives it out, which can be a few messages after
    its own (B-frames): log times then repeat the video topic's order, not the merged order.

    Args:
        messages: Messages in log-time order.
        start_ns: Drop every message (video or not) logged before this time (ns); frames before
            it are still decoded, as the reference frames of later ones.

    Yields:
        The messages, video ones decoded.
    """
    decoders: dict[str, VideoDecoder | None] = {}
    formats: dict[str, str] = {}

    def wrap(topic: str, frames: list[VideoFrame]) -> Iterator[Message]:
        for f in frames:
            if start_ns is None or f.log_time_ns >= start_ns:
                data = DecodedImage(f.image, formats[topic], f.skipped)
                yield Message(topic, f.log_time_ns, f.stamp_ns, DECODED_MSGTYPE, data)

    for msg in messages:
        codec = message_codec(msg)
        if codec is None:
            if start_ns is None or msg.log_time_ns >= start_ns:
                yield msg
            continue
        if msg.topic not in decoders:
            formats[msg.topic] = str(field_value(msg.data, "format") or codec)
            decoders[msg.topic] = VideoDecoder(codec) if decoder_available(codec) else None
        decoder = decoders[msg.topic]
        if decoder is None:
            reason = f"this FFmpeg build has no {codec} decoder"
            yield from wrap(msg.topic, [VideoFrame(msg.log_time_ns, msg.stamp_ns, None, reason)])
            continue
        payload = field_value(msg.data, "data")
        raw = b"" if payload is None else payload if isinstance(payload, bytes) else bytes(payload)
        yield from wrap(msg.topic, decoder.feed(msg.log_time_ns, msg.stamp_ns, raw))
    for topic, decoder in decoders.items():
        if decoder is not None:
            yield from wrap(topic, decoder.flush())


def keyframe_before(rec: Recording, topic: str, start_ns: int) -> int | None:
    """Return the log time (ns) of the last keyframe of a video topic at or before ``start_ns``.

    Looks back in growing windows (5 s, 30 s, 120 s, then the whole recording), so a seek costs
    one GOP of reading, not the recording up to the start.

    Returns:
        The keyframe's log time, or None when the topic is not video or has no keyframe before.
    """
    windows: list[int | None] = [start_ns - round(w * _NS) for w in _SEEK_WINDOWS_S]
    windows.append(None)
    for window_start in windows:
        last: int | None = None
        for msg in rec.messages(topics=[topic], start_ns=window_start, stop_ns=start_ns + 1):
            codec = message_codec(msg)
            if codec is None:
                return None
            payload = field_value(msg.data, "data")
            if payload is not None and is_keyframe(codec, bytes(payload)):
                last = msg.log_time_ns
        if last is not None:
            return last
    return None


def read_with_video(
    rec: Recording,
    topics: Collection[str] | None = None,
    start_ns: int | None = None,
    stop_ns: int | None = None,
) -> Iterator[Message]:
    """Yield ``rec.messages(...)`` with video decoded, seeking video back to a keyframe.

    With ``start_ns``, reading starts at the last keyframe before it on every video topic, the
    frames in between are decoded (as references) but not yielded, so the first frame yielded
    is the first one logged at or after ``start_ns``.
    """
    read_from = start_ns
    if start_ns is not None:
        names = list(topics) if topics is not None else [t.topic for t in rec.topics()]
        kinds = VIDEO_MSGTYPES | COMPRESSED_IMAGE_TYPES
        video = [t.topic for t in rec.topics() if t.topic in names and t.msgtype in kinds]
        for topic in video:
            key = keyframe_before(rec, topic, start_ns)
            if key is not None and (read_from is None or key < read_from):
                read_from = key
    messages = rec.messages(topics=topics, start_ns=read_from, stop_ns=stop_ns)
    return decode_video(messages, start_ns=start_ns)


ENCODERS = {"h264": "libx264", "h265": "libx265"}
"""Video formats :class:`VideoEncoder` writes -> FFmpeg encoder names."""


class VideoEncoder:
    """Encode BGR frames one at a time into one access unit each (no B-frames, no delay).

    Each call returns the bytes of exactly the frame given, so every frame can be one
    ``CompressedVideo`` message at its own time; a keyframe (with its parameter sets) starts
    every ``gop`` frames.

    Args:
        fmt: ``h264`` or ``h265``.
        width: Frame width, pixels (even).
        height: Frame height, pixels (even).
        fps: Frame rate, Hz (the encoder's rate control uses it).
        crf: Constant rate factor (lower: better quality, bigger frames; x264 default 23).
        gop: Frames per group of pictures (keyframe interval).

    Raises:
        RecordingError: For an unknown format, odd sizes or a missing encoder.
    """

    def __init__(
        self, fmt: str, width: int, height: int, fps: float, crf: int = 23, gop: int = 15
    ) -> None:
        import fractions

        import av

        name = ENCODERS.get(fmt)
        if name is None:
            raise RecordingError(f"video format must be one of {', '.join(ENCODERS)}, got {fmt!r}")
        if name not in av.codecs_available:
            raise RecordingError(f"this FFmpeg build has no {name} encoder")
        if width % 2 or height % 2 or width <= 0 or height <= 0:
            raise RecordingError(f"video frames need an even size, got {width}x{height}")
        self.fmt = fmt
        self.size = (width, height)
        ctx: Any = av.CodecContext.create(name, "w")
        ctx.width, ctx.height = width, height
        ctx.pix_fmt = "yuv420p"
        ctx.time_base = fractions.Fraction(1, 1000)
        ctx.framerate = fractions.Fraction(round(fps * 1000), 1000)
        ctx.gop_size = max(1, gop)
        ctx.max_b_frames = 0
        ctx.thread_count = 1  # deterministic output
        params = f"keyint={max(1, gop)}:min-keyint={max(1, gop)}:scenecut=0"
        ctx.options = {
            "preset": "veryfast",
            "tune": "zerolatency",
            "crf": str(crf),
            ("x264-params" if fmt == "h264" else "x265-params"): params
            + (":log-level=error" if fmt == "h265" else ""),
        }
        self._ctx = ctx
        self._index = 0
        self._ms_per_frame = 1000.0 / fps

    def encode(self, image_bgr: NDArray[np.uint8]) -> bytes:
        """Encode one BGR frame; return its access unit (Annex B bytes)."""
        import av

        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image_bgr), format="bgr24")
        frame.pts = round(self._index * self._ms_per_frame)
        self._index += 1
        packets = self._ctx.encode(frame)
        return b"".join(bytes(p) for p in packets)
