"""The one frame reader: a camera topic's frames decoded, video included.

Every reader of camera frames outside the streaming pass (``slt mine``'s label sets and image
statistics, ``slt segment`` / ``slt corridor`` / ``slt camera estimate`` on a recording, the
reprocess self-check) goes through :func:`camera_frames`: messages come from
:func:`~superlane_tools.recording.video.read_with_video` (JPEG, PNG, raw and H.264 / H.265 / AV1
/ VP9 ``CompressedVideo`` alike; a seek starts at the keyframe before it), each frame is decoded
once, at a reduced size where the caller asks for one.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator
from typing import TYPE_CHECKING, Any, NamedTuple

from superlane_tools.recording.base import Recording
from superlane_tools.recording.images import decode_frame, decode_reduced
from superlane_tools.recording.video import read_with_video
from superlane_tools.records import Message

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray


class CameraFrame(NamedTuple):
    """One camera frame of a recording.

    Attributes:
        message: The message as read (a video frame: the decoded frame's message); its
            ``log_time_ns`` is the frame's time, its payload the recorded bytes.
        image: BGR pixels (None when the frame did not decode; ``error`` says why).
        size: Recorded (source) ``(width, height)``, pixels ((0, 0) when it did not decode).
        error: Why the frame did not decode ("" when it did).
    """

    message: Message
    image: NDArray[np.uint8] | None
    size: tuple[int, int]
    error: str

    @property
    def log_time_ns(self) -> int:
        """The frame's log time, ns."""
        return self.message.log_time_ns


def camera_frames(
    recording: Recording,
    topic: str,
    times: Collection[int] | None = None,
    width: int | None = None,
) -> Iterator[CameraFrame]:
    """Yield the frames of ``topic`` in log-time order, decoded.

    Args:
        recording: An open recording
            (:func:`~superlane_tools.recording.open.open_recording`).
        topic: The camera topic (image, compressed image or video).
        times: Only the frames logged at these times (ns); the recording is read from the
            first to the last of them (video from the keyframe before the first). None: every
            frame.
        width: Decode JPEG frames directly at a reduced size still at least this wide, pixels
            (:func:`~superlane_tools.recording.images.decode_reduced`); other frames, and all
            with None, are decoded at full size.

    Yields:
        One :class:`CameraFrame` per frame read, also for frames that do not decode.
    """
    wanted = None if times is None else set(times)
    if wanted is not None and not wanted:
        return
    window = (None, None) if wanted is None else (min(wanted), max(wanted) + 1)
    for msg in read_with_video(recording, [topic], *window):
        if msg.topic != topic or (wanted is not None and msg.log_time_ns not in wanted):
            continue
        yield _decoded(msg, width)


def _decoded(msg: Message, width: int | None) -> CameraFrame:
    """Decode one frame (reduced when ``width`` allows); an undecodable one keeps its error."""
    try:
        reduced = decode_reduced(msg, width) if width is not None else None
        if reduced is not None:
            return CameraFrame(msg, reduced[0], reduced[1], "")
        image: Any = decode_frame(msg)
    except ValueError as err:
        return CameraFrame(msg, None, (0, 0), str(err))
    return CameraFrame(msg, image, (int(image.shape[1]), int(image.shape[0])), "")
