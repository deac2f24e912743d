"""Each method's unavailable frames counted by reason and worded with their numbers."""

from __future__ import annotations

import numpy as np

from superlane_tools.corridor import AvailabilityParams
from superlane_tools.reporting.availability_reasons import method_reasons, reasons_table
from superlane_tools.reporting.drive_tables import availability_tables


def _frames(speed: np.ndarray) -> object:
    n = speed.size
    t = (np.arange(n) * 1e9 / 10).astype(np.int64)
    width = np.full(n, 3.6)
    length = np.full(n, 40.0)
    length[:6] = [10.0, 12.0, 14.0, 16.0, 30.0, 30.0]  # 4 too short at 25 m/s (17.5 m needed)
    width[4] = 1.5  # too narrow
    width[5] = np.nan  # no corridor
    nan = np.full(n, np.nan)
    geometry = {
        "super": (width, length),
        "corridor_net": (width, length),
        "hough": (width, length),
        "mobileye": (nan, nan),
    }
    frames, _, _ = availability_tables(
        t, geometry, {"mobileye": "no Mobileye lane messages"}, speed, AvailabilityParams(), None
    )
    return frames


def test_reasons_are_counted_and_worded() -> None:
    frames = _frames(np.full(20, 25.0))
    (sup,) = method_reasons(frames, ["super"], 2.0, 6.0)
    assert (sup.n_frames, sup.n_available, sup.n_unknown) == (20, 14, 0)
    assert [(r.reason, r.n_frames) for r in sup.reasons] == [
        ("too short", 4),
        ("no corridor", 1),
        ("too narrow", 1),
    ]
    assert sup.summary() == (
        "SUPER 70 % available: 4 of 20 frames too short (median reach 13.0 m, 17.5 m needed); "
        "1 no ego line pair fitted; 1 too narrow (median width 1.50 m, 2 m needed)"
    )
    table = reasons_table([sup])
    assert table["frames"].sum() == 20
    assert table["state"].iloc[0] == "available"


def test_unknown_frames_are_not_a_reason() -> None:
    speed = np.full(20, np.nan)
    speed[:2] = 25.0  # two frames with a speed: both too short
    (sup,) = method_reasons(_frames(speed), ["super"], 2.0, 6.0)
    assert sup.n_unknown == 16  # frames 6..19 and 2, 3 (width fine, no speed)
    assert sup.summary().startswith(
        "SUPER 0 % available (16 of 20 frames unknown: no speed): 2 of 20 frames too short"
    )
    (none,) = method_reasons(_frames(np.full(20, np.nan)), ["hough"], 2.0, 6.0)
    assert none.n_unknown == 18  # the narrow frame and the frame without a corridor are known
    everything = method_reasons(_frames(np.full(20, np.nan)), ["mobileye"], 2.0, 6.0)
    assert everything[0].reasons == ()  # a method that did not run has no reasons
