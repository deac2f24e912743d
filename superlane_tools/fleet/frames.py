"""Camera frames of a recording, for ``slt mine``, read through the video-aware reader.

Frames come from :func:`~superlane_tools.recording.camera_frames.camera_frames`, the one frame
reader (JPEG, PNG, raw and H.264 / H.265 / AV1 / VP9 ``CompressedVideo`` topics alike), so a
video camera yields the same picks as a JPEG one. :func:`frame_jpegs` gives the frames at chosen
log times as JPEGs at their recorded (source) size, the mined label set;
:func:`gray_frames` every frame reduced to grayscale, for the ``low_light`` criterion.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.fleet.errors import FleetError
from superlane_tools.recording import open_recording
from superlane_tools.recording.base import field_value
from superlane_tools.recording.camera_frames import camera_frames
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.images import sniff_format
from superlane_tools.recording.streams import RAW_IMAGE_TYPES
from superlane_tools.recording.video import DECODED_MSGTYPE
from superlane_tools.records import Message


class FrameJpeg(NamedTuple):
    """One camera frame as saved in a label set.

    Attributes:
        data: JPEG bytes: the recorded JPEG itself when the frame was one, else the decoded
            pixels encoded (video, PNG, raw).
        width: Recorded (source) width, pixels.
        height: Recorded (source) height, pixels.
    """

    data: bytes
    width: int
    height: int


def _recorded_jpeg(msg: Message) -> bytes | None:
    """Return the message's payload when it is a JPEG image (kept as recorded, no re-encode)."""
    if msg.msgtype in RAW_IMAGE_TYPES or msg.msgtype == DECODED_MSGTYPE:
        return None
    payload = field_value(msg.data, "data")
    if payload is None:
        return None
    raw = payload if isinstance(payload, bytes) else bytes(payload)
    return raw if sniff_format(raw) == "jpeg" else None


def frame_jpegs(recording: Path, topic: str, times_ns: Collection[int]) -> dict[int, FrameJpeg]:
    """Return log time -> JPEG at source size of the camera frames of ``topic`` at ``times_ns``.

    Video topics are read from the last keyframe before the first wanted time, so every wanted
    frame decodes. Frames that do not decode are left out (the caller reports them).

    Raises:
        FleetError: If the recording cannot be opened or read.
    """
    import cv2  # late: heavy import

    wanted = set(times_ns)
    out: dict[int, FrameJpeg] = {}
    if not wanted:
        return out
    try:
        with open_recording(recording) as rec:
            for frame in camera_frames(rec, topic, wanted):
                if frame.image is None:
                    continue
                data = _recorded_jpeg(frame.message)
                if data is None:
                    params = [cv2.IMWRITE_JPEG_QUALITY, 95]
                    ok, encoded = cv2.imencode(".jpg", frame.image, params)
                    if not ok:
                        continue
                    data = encoded.tobytes()
                width, height = frame.image.shape[1], frame.image.shape[0]
                out[frame.log_time_ns] = FrameJpeg(data, int(width), int(height))
    except RecordingError as err:
        raise FleetError(f"{recording}: {err}") from err
    return out


GRAY_WIDTH = 160
"""Width (pixels) frames are reduced to for image statistics: enough for a mean and a contrast."""


def gray_frames(
    recording: Path, topic: str, width: int = GRAY_WIDTH
) -> Iterator[tuple[int, NDArray[np.uint8]]]:
    """Yield ``(log time, grayscale image about ``width`` wide)`` for every frame of ``topic``.

    JPEG frames are decoded directly at a reduced size where one still covers ``width``
    (:func:`~superlane_tools.recording.images.decode_reduced`), video frames by the video
    decoder, then resized. Frames that do not decode are left out (the caller reports them).

    Raises:
        FleetError: If the recording cannot be opened or read.
    """
    import cv2  # late: heavy import

    try:
        with open_recording(recording) as rec:
            for frame in camera_frames(rec, topic, width=width):
                if frame.image is None:
                    continue
                gray = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
                if gray.shape[1] > width:
                    height = max(1, round(gray.shape[0] * width / gray.shape[1]))
                    gray = cv2.resize(gray, (width, height), interpolation=cv2.INTER_AREA)
                yield frame.log_time_ns, np.asarray(gray, np.uint8)
    except RecordingError as err:
        raise FleetError(f"{recording}: {err}") from err
