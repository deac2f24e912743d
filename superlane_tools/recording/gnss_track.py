"""A recording's GNSS track in local east/north metres (for camera estimation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.geo import geodetic_to_enu, valid_fixes
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.streams import GNSS_TYPES

Track = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""Log time ns, east m, north m."""


def gnss_track(recording: Path) -> Track | None:
    """Return ``(log time ns, east m, north m)`` of the recording's first GNSS topic, or None."""
    with open_recording(recording) as rec:
        topics = sorted(t.topic for t in rec.topics() if t.msgtype in GNSS_TYPES)
        if not topics:
            return None
        rows = [
            (m.log_time_ns, m.data.latitude, m.data.longitude, m.data.altitude)
            for m in rec.messages(topics=topics[:1])
        ]
    if len(rows) < 2:
        return None
    arr = np.asarray(rows, dtype=np.float64)
    ok = valid_fixes(arr[:, 1], arr[:, 2], arr[:, 3])
    if ok.sum() < 2:
        return None
    enu = geodetic_to_enu(arr[ok, 1], arr[ok, 2], arr[ok, 3])
    return arr[ok, 0], enu.east_m, enu.north_m
