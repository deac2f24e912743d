"""Camera frames of a recording, for ``slt mine``.

JPEG bytes at chosen log times (the mined label set) and reduced grayscale frames (the
``low_light`` criterion).
"""

from __future__ import annotations

from collections.abc import Collection, Iterator
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.fleet.errors import FleetError
from superlane_tools.recording import open_recording
from superlane_tools.recording.errors import RecordingError


def frame_jpegs(recording: Path, topic: str, times_ns: Collection[int]) -> dict[int, bytes]:
    """Return log time -> JPEG of the camera frames of ``topic`` at ``times_ns``.

    Frames that do not decode are left out (the caller reports them).

    Raises:
        FleetError: If the recording cannot be opened or read.
    """
    import cv2  # late: heavy import

    from superlane_tools.recording.images import decode_frame

    wanted = set(times_ns)
    out: dict[int, bytes] = {}
    if not wanted:
        return out
    try:
        with open_recording(recording) as rec:
            for msg in rec.messages([topic], min(wanted), max(wanted) + 1):
                if msg.log_time_ns not in wanted:
                    continue
                try:
                    ok, data = cv2.imencode(".jpg", decode_frame(msg))
                except ValueError:
                    continue
                if ok:
                    out[msg.log_time_ns] = data.tobytes()
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
    (:func:`~superlane_tools.recording.images.decode_reduced`), then resized. Frames that do not
    decode are left out (the caller reports them).

    Raises:
        FleetError: If the recording cannot be opened or read.
    """
    import cv2  # late: heavy import

    from superlane_tools.recording.images import decode_frame, decode_reduced

    try:
        with open_recording(recording) as rec:
            for msg in rec.messages([topic]):
                try:
                    reduced = decode_reduced(msg, width)
                    bgr = reduced[0] if reduced is not None else decode_frame(msg)
                except ValueError:
                    continue
                gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
                if gray.shape[1] > width:
                    height = max(1, round(gray.shape[0] * width / gray.shape[1]))
                    gray = cv2.resize(gray, (width, height), interpolation=cv2.INTER_AREA)
                yield msg.log_time_ns, np.asarray(gray, np.uint8)
    except RecordingError as err:
        raise FleetError(f"{recording}: {err}") from err
