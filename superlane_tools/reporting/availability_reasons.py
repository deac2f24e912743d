"""Why each method's frames were not available, in words, from the per-frame availability table.

``availability_frames`` carries one reason per frame and method (``corridor.availability``'s
reason strings); this module counts them per method and words each with its numbers ("too
short (median reach 15.7 m, 18.8 m needed)"), so the headline can name the dominant reason and
the availability section can list them all.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import pandas as pd

from superlane_tools.corridor.availability import (
    NO_CORRIDOR,
    SPEED_UNKNOWN,
    TOO_NARROW,
    TOO_SHORT,
    TOO_WIDE,
)
from superlane_tools.reporting.names import AVAILABILITY_NAMES, METHOD_NOT_RUN

NOT_DECODED = "frame not decoded"
"""``availability_frames.reason`` of an image method's frame whose image could not be decoded."""

NOT_PLAUSIBLE = "not plausible"
"""``availability_frames.reason`` of a SUPER frame whose fit is not plausible (collapsed view)."""

NO_CORRIDOR_TEXT = {
    "super": "no ego line pair fitted",
    "corridor_net": "no corridor in the network's mask",
    "hough": "no ego line pair found by Hough",
    "mobileye": "no two ego lines of quality >= 2",
}
"""What "no corridor" means for each method."""


class ReasonCount(NamedTuple):
    """Frames of one method that share one reason for not being available.

    Attributes:
        reason: The ``availability_frames.reason`` value.
        n_frames: Frames with that reason.
        text: The reason in words, with its numbers.
    """

    reason: str
    n_frames: int
    text: str


class MethodReasons(NamedTuple):
    """One method's frames: how many available, unknown, and why the others were not.

    Attributes:
        method: Availability method.
        n_frames: Frames.
        n_available: Frames available.
        n_unknown: Frames of unknown availability (no speed).
        reasons: Unavailable frames by reason, most frequent first (ties by name; unknown
            frames excluded).
    """

    method: str
    n_frames: int
    n_available: int
    n_unknown: int
    reasons: tuple[ReasonCount, ...]

    @property
    def name(self) -> str:
        """Display name of the method."""
        return AVAILABILITY_NAMES.get(self.method, self.method)

    def summary(self) -> str:
        """One sentence: the share available and the dominant reason of the others.

        E.g. ``SUPER 36 % available: 153 of 240 frames too short (median reach 15.7 m, 18.8 m
        needed)``; ``SUPER unknown on every frame (no speed)``.
        """
        n = self.n_frames
        if n and self.n_unknown >= n:
            return f"{self.name} unknown on every frame (no speed to judge the corridor length)"
        head = f"{self.name} {_percent(self.n_available, n)} available"
        if self.n_unknown:
            head += f" ({self.n_unknown} of {n} frames unknown: no speed)"
        if not self.reasons:
            return head
        top, *rest = self.reasons
        also = "".join(f"; {r.n_frames} {r.text}" for r in rest[:2])
        if len(rest) > 2:
            also += f"; {sum(r.n_frames for r in rest[2:])} for other reasons"
        return f"{head}: {top.n_frames} of {n} frames {top.text}{also}"


def _percent(k: int, n: int) -> str:
    if not n:
        return "n/a"
    share = 100.0 * k / n
    return f"{share:.0f} %" if share >= 1 or k == 0 else f"{share:.1f} %"


def method_reasons(
    frames: pd.DataFrame, methods: Sequence[str], min_width_m: float, max_width_m: float
) -> list[MethodReasons]:
    """Count and word the reasons of every method in ``methods`` (those that ran).

    Args:
        frames: ``availability_frames`` (``method``, ``available``, ``known``, ``reason``,
            ``width_m``, ``length_m``, ``required_length_m``).
        methods: Methods to describe, in order.
        min_width_m: The narrowest usable corridor, metres (quoted for "too narrow").
        max_width_m: The widest usable corridor, metres (quoted for "too wide").
    """
    out = []
    for method in methods:
        sel = frames[frames["method"] == method]
        if sel.empty:
            continue
        reason = sel["reason"].astype(str)
        counted = sel[~sel["available"].astype(bool) & sel["known"].astype(bool)]
        counts = counted["reason"].astype(str).value_counts(sort=True)
        reasons = tuple(
            ReasonCount(
                str(r),
                int(k),
                _words(method, str(r), counted[counted["reason"] == r], (min_width_m, max_width_m)),
            )
            for r, k in counts.items()
            if not str(r).startswith(METHOD_NOT_RUN)
        )
        out.append(
            MethodReasons(
                method,
                len(sel),
                int(sel["available"].astype(bool).sum()),
                int((reason == SPEED_UNKNOWN).sum()),
                tuple(sorted(reasons, key=lambda rc: (-rc.n_frames, rc.reason))),
            )
        )
    return out


def _median(values: pd.Series) -> float:
    finite = values.to_numpy(dtype=np.float64)
    finite = finite[np.isfinite(finite)]
    return float(np.median(finite)) if finite.size else math.nan


def _words(method: str, reason: str, rows: pd.DataFrame, bounds: tuple[float, float]) -> str:
    """The reason in words, with the numbers of the frames it concerns."""
    if reason == TOO_SHORT:
        return (
            f"too short (median reach {_median(rows['length_m']):.1f} m, "
            f"{_median(rows['required_length_m']):.1f} m needed)"
        )
    if reason == TOO_NARROW:
        return f"too narrow (median width {_median(rows['width_m']):.2f} m, {bounds[0]:g} m needed)"
    if reason == TOO_WIDE:
        return f"too wide (median width {_median(rows['width_m']):.2f} m, at most {bounds[1]:g} m)"
    if reason == NO_CORRIDOR:
        return NO_CORRIDOR_TEXT.get(method, "no corridor")
    if reason == NOT_PLAUSIBLE:
        return "fit not plausible (road slope at its bound: the view collapsed)"
    return reason


def reasons_table(reasons: Sequence[MethodReasons]) -> pd.DataFrame:
    """One row per method and reason: frames and their share of the method's frames."""
    rows: list[dict[str, object]] = []
    for m in reasons:
        rows.append(
            {
                "method": m.name,
                "frames": m.n_available,
                "share": _percent(m.n_available, m.n_frames),
                "state": "available",
            }
        )
        rows.extend(
            {
                "method": m.name,
                "frames": r.n_frames,
                "share": _percent(r.n_frames, m.n_frames),
                "state": f"not available: {r.text}",
            }
            for r in m.reasons
        )
        if m.n_unknown:
            rows.append(
                {
                    "method": m.name,
                    "frames": m.n_unknown,
                    "share": _percent(m.n_unknown, m.n_frames),
                    "state": "unknown: no speed to judge the corridor length",
                }
            )
    return pd.DataFrame(rows, columns=["method", "state", "frames", "share"])
