"""Camera frames of a recording at chosen log times, as JPEG bytes (for a mined label set)."""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

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
