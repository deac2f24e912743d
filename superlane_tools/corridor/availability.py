"""Lateral-control availability KPIs per frame and per sequence (corridor paper, IV-B, Table II).

Per frame, lateral control is *available* when the ego-corridor width lies in
``[min_width_m, max_width_m]`` (default 2-6 m) and its length is at least the time-gap distance
``speed_mps * time_gap_s`` (default 0.7 s). When the speed is unknown (NaN) and the width test
passes, availability is *unknown* rather than False.

Per sequence (consecutive windows of ``window_frames`` frames, default 450 = 30 s at 15 Hz, or
given segments with category labels):

* frame-based ratio ``n / N``: available frames over all frames of the sequence;
* sequence-based availability: the sequence is available when it has no outage longer than
  ``max_outage_s`` (default the paper's 5 frames at 15 Hz, 1/3 s); with frame times, frames
  missing from the recording (dropped: a time step over 1.5 frame periods) count as outage,
  so a camera that drops frames cannot look available; without them, the limit is
  ``max_outage_frames`` consecutive unavailable frames;
* longest outage, in frames and seconds.

Frames of unknown availability count as unavailable in the pessimistic outage and as available
in the optimistic one; when the two disagree the sequence decision is unknown (None). They never
count as outage in the reported longest outage (frames known to be unavailable, and dropped
frames, only), and a sequence whose every frame is unknown has no ratio (NaN), not 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from superlane_tools.corridor.errors import CorridorError

BoolArray = NDArray[np.bool_]

OK = ""
NO_CORRIDOR = "no corridor"
TOO_NARROW = "too narrow"
TOO_WIDE = "too wide"
TOO_SHORT = "too short"
SPEED_UNKNOWN = "speed unknown"


@dataclass(frozen=True)
class AvailabilityParams:
    """Thresholds of the availability KPIs.

    Attributes:
        min_width_m: Narrowest usable corridor, metres.
        max_width_m: Widest usable corridor, metres.
        time_gap_s: The corridor must reach ``speed * time_gap_s`` ahead, seconds.
        width_at_m: Forward distance at which every method measures the corridor width,
            metres (at the corridor's far end when it is shorter); reported beside the width.
        max_outage_frames: A sequence stays available with outages up to this many frames.
        window_frames: Frames per sequence when the drive is cut into consecutive windows.
        frame_rate_hz: Camera frame rate, for outages in seconds.
        max_outage_s: Longest tolerated outage, seconds (None or 0: ``max_outage_frames`` frames
            at ``frame_rate_hz``); used when frame times are given.
    """

    min_width_m: float = 2.0
    max_width_m: float = 6.0
    time_gap_s: float = 0.7
    width_at_m: float = 10.0
    max_outage_frames: int = 5
    window_frames: int = 450
    frame_rate_hz: float = 15.0
    max_outage_s: float | None = None

    @property
    def outage_limit_s(self) -> float:
        """The longest tolerated outage, seconds."""
        if self.max_outage_s is not None and self.max_outage_s > 0:
            return self.max_outage_s
        return self.max_outage_frames / self.frame_rate_hz

    def __post_init__(self) -> None:
        if not 0 <= self.min_width_m <= self.max_width_m:
            raise CorridorError(
                f"need 0 <= min_width_m <= max_width_m, got {self.min_width_m}, {self.max_width_m}"
            )
        if self.window_frames < 1 or self.frame_rate_hz <= 0 or self.max_outage_frames < 0:
            raise CorridorError("window_frames >= 1, frame_rate_hz > 0, max_outage_frames >= 0")


class FrameAvailability(NamedTuple):
    """Per-frame availability, arrays of length N.

    Attributes:
        available: True where lateral control is available (False where unknown).
        known: False where availability is unknown (speed missing, width usable).
        reason: Why not available (``""`` when available); one of the module's reason strings.
    """

    available: BoolArray
    known: BoolArray
    reason: NDArray[np.str_]


class Segment(NamedTuple):
    """A labelled frame range ``[start, stop)`` evaluated as one sequence."""

    start: int
    stop: int
    category: str = ""


class SequenceAvailability(NamedTuple):
    """Availability KPIs of one sequence.

    Attributes:
        start: First frame index.
        stop: One past the last frame index.
        category: Category label (``""`` for plain windows).
        n_frames: Frames in the sequence (N).
        n_available: Available frames (n).
        n_unknown: Frames of unknown availability.
        ratio: ``n / N``; NaN when every frame is unknown.
        available: Sequence-based availability; None when unknown frames decide it.
        longest_outage_frames: Longest run of frames known to be unavailable (unknown frames
            are not outage).
        longest_outage_s: The longest outage in seconds (known-unavailable and dropped frames).
    """

    start: int
    stop: int
    category: str
    n_frames: int
    n_available: int
    n_unknown: int
    ratio: float
    available: bool | None
    longest_outage_frames: int
    longest_outage_s: float


def frame_availability(
    width_m: ArrayLike,
    length_m: ArrayLike,
    speed_mps: ArrayLike,
    params: AvailabilityParams | None = None,
) -> FrameAvailability:
    """Decide per frame whether lateral control is available.

    Args:
        width_m: Corridor width per frame, metres (NaN: no corridor).
        length_m: Corridor length per frame, metres (NaN: no corridor).
        speed_mps: Vehicle speed per frame, m/s (NaN: unknown), or one value for all frames.
        params: Thresholds.

    Raises:
        CorridorError: If the arrays have different lengths.
    """
    p = params or AvailabilityParams()
    width = np.atleast_1d(np.asarray(width_m, dtype=np.float64))
    length = np.atleast_1d(np.asarray(length_m, dtype=np.float64))
    speed = np.asarray(speed_mps, dtype=np.float64)
    if speed.ndim == 0:
        speed = np.full(width.shape, float(speed))
    if not width.shape == length.shape == speed.shape or width.ndim != 1:
        raise CorridorError(
            f"width, length and speed need one value per frame, got shapes "
            f"{width.shape}, {length.shape}, {speed.shape}"
        )
    no_corridor = ~np.isfinite(width) | ~np.isfinite(length) | (length <= 0)
    narrow = ~no_corridor & (width < p.min_width_m)
    wide = ~no_corridor & (width > p.max_width_m)
    width_ok = ~no_corridor & ~narrow & ~wide
    speed_known = np.isfinite(speed)
    with np.errstate(invalid="ignore"):
        short = width_ok & speed_known & (length < np.abs(speed) * p.time_gap_s)
    unknown = width_ok & ~speed_known
    available = width_ok & speed_known & ~short
    reason = np.full(width.shape, OK, dtype="<U13")
    reason[no_corridor] = NO_CORRIDOR
    reason[narrow] = TOO_NARROW
    reason[wide] = TOO_WIDE
    reason[short] = TOO_SHORT
    reason[unknown] = SPEED_UNKNOWN
    return FrameAvailability(available, ~unknown, reason)


def longest_run(flags: BoolArray) -> int:
    """Return the length of the longest run of True in a 1-D boolean array."""
    f = np.asarray(flags, dtype=np.int8)
    if f.size == 0 or not f.any():
        return 0
    edges = np.diff(np.concatenate(([0], f, [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return int((stops - starts).max())


def longest_outage_s(unavailable: BoolArray, t_ns: NDArray[np.int64], period_s: float) -> float:
    """Return the longest outage in seconds, counting dropped frames as outage.

    Each frame stands for one frame period; a time step longer than 1.5 periods between two
    frames adds the missing time (dropped frames) to the outage it falls in, or starts one.

    Args:
        unavailable: (N,) True where the frame is not available.
        t_ns: (N,) frame times, integer nanoseconds, increasing.
        period_s: Nominal frame period, seconds.

    Returns:
        The longest outage, seconds (0.0 when there is none).
    """
    bad = np.asarray(unavailable, dtype=bool)
    t = np.asarray(t_ns, dtype=np.int64)
    longest = current = 0.0
    for i in range(bad.size):
        if i:
            gap = (t[i] - t[i - 1]) * 1e-9 - period_s
            if gap > 0.5 * period_s:
                current += gap
        if bad[i]:
            current += period_s
        else:
            longest = max(longest, current)
            current = 0.0
    return max(longest, current)


class TimeSegment(NamedTuple):
    """A labelled sequence of a drive in time: ``[start_s, stop_s)`` after the first frame."""

    start_s: float
    stop_s: float
    category: str = ""


def segments_at_times(t_ns: NDArray[np.int64], specs: Sequence[TimeSegment]) -> list[Segment]:
    """Turn time segments into frame ranges of frames at ``t_ns``; empty ranges are dropped."""
    if len(t_ns) == 0:
        return []
    rel = (t_ns - t_ns[0]) / 1e9
    out = []
    for spec in specs:
        start = int(np.searchsorted(rel, spec.start_s, "left"))
        stop = int(np.searchsorted(rel, spec.stop_s, "left"))
        if stop > start:
            out.append(Segment(start, stop, spec.category))
    return out


def windows(n_frames: int, window_frames: int) -> list[Segment]:
    """Cut ``n_frames`` into consecutive windows; the last one may be shorter."""
    return [
        Segment(start, min(start + window_frames, n_frames))
        for start in range(0, n_frames, window_frames)
    ]


def sequence_availability(
    frames: FrameAvailability,
    params: AvailabilityParams | None = None,
    segments: Sequence[Segment] | None = None,
    t_ns: NDArray[np.int64] | None = None,
) -> list[SequenceAvailability]:
    """Compute the sequence KPIs over windows or labelled segments.

    Args:
        frames: Per-frame availability (from :func:`frame_availability`).
        params: Thresholds, window length and frame rate.
        segments: Labelled ``[start, stop)`` frame ranges; None cuts consecutive windows of
            ``params.window_frames`` (the last may be shorter).
        t_ns: Frame times, integer nanoseconds: outages are then measured in seconds against
            ``params.outage_limit_s`` and dropped frames count as outage.

    Raises:
        CorridorError: If a segment is empty or outside the frames.
    """
    p = params or AvailabilityParams()
    n = int(frames.available.shape[0])
    spans = list(segments) if segments is not None else windows(n, p.window_frames)
    out: list[SequenceAvailability] = []
    for seg in spans:
        if not 0 <= seg.start < seg.stop <= n:
            raise CorridorError(f"segment [{seg.start}, {seg.stop}) outside frames [0, {n})")
        avail = frames.available[seg.start : seg.stop]
        known = frames.known[seg.start : seg.stop]
        pessimistic = longest_run(~avail)
        optimistic = longest_run(~avail & known)
        if t_ns is None:
            ok_pess = pessimistic <= p.max_outage_frames
            ok_opt = optimistic <= p.max_outage_frames
            outage_s = optimistic / p.frame_rate_hz
        else:
            times = np.asarray(t_ns, dtype=np.int64)[seg.start : seg.stop]
            period = 1.0 / p.frame_rate_hz
            outage_s = longest_outage_s(~avail & known, times, period)
            limit = p.outage_limit_s + 1e-6
            ok_pess = bool(longest_outage_s(~avail, times, period) <= limit)
            ok_opt = bool(outage_s <= limit)
        decided: bool | None = ok_pess if ok_pess == ok_opt else None
        size = seg.stop - seg.start
        n_avail = int(avail.sum())
        n_unknown = int((~known).sum())
        out.append(
            SequenceAvailability(
                start=seg.start,
                stop=seg.stop,
                category=seg.category,
                n_frames=size,
                n_available=n_avail,
                n_unknown=n_unknown,
                ratio=n_avail / size if n_unknown < size else float("nan"),
                available=decided,
                longest_outage_frames=optimistic,
                longest_outage_s=outage_s,
            )
        )
    return out
