"""Tests of the availability KPIs on hand-made sequences and random ones (Hypothesis)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from superlane_tools.corridor import (
    AvailabilityParams,
    CorridorError,
    Segment,
    frame_availability,
    longest_run,
    sequence_availability,
)


def test_reasons_per_frame() -> None:
    width = [3.5, 1.5, 7.0, 3.5, math.nan, 3.5, 3.5]
    length = [40.0, 40.0, 40.0, 10.0, 40.0, 40.0, math.nan]
    speed = [20.0, 20.0, 20.0, 20.0, 20.0, math.nan, 20.0]
    frames = frame_availability(width, length, speed)
    assert frames.available.tolist() == [True, False, False, False, False, False, False]
    assert frames.known.tolist() == [True, True, True, True, True, False, True]
    assert frames.reason.tolist() == [
        "",
        "too narrow",
        "too wide",
        "too short",
        "no corridor",
        "speed unknown",
        "no corridor",
    ]


def test_length_threshold_is_the_time_gap_distance() -> None:
    params = AvailabilityParams(time_gap_s=1.0)
    frames = frame_availability([3.0, 3.0], [19.9, 20.0], 20.0, params)
    assert frames.available.tolist() == [False, True]


def test_hand_made_sequence_windows() -> None:
    n = 900
    width = np.full(n, 3.5)
    width[100:105] = 1.0  # 5-frame outage: tolerated
    width[600:606] = 1.0  # 6-frame outage: the second window is not available
    frames = frame_availability(width, np.full(n, 50.0), np.full(n, 25.0))
    seqs = sequence_availability(frames)
    assert [(s.start, s.stop) for s in seqs] == [(0, 450), (450, 900)]
    assert [s.available for s in seqs] == [True, False]
    assert [s.n_available for s in seqs] == [445, 444]
    assert seqs[0].ratio == pytest.approx(445 / 450)
    assert seqs[1].longest_outage_frames == 6
    assert seqs[1].longest_outage_s == pytest.approx(6 / 15)


def test_segments_with_categories_and_unknown_speed() -> None:
    n = 100
    speed = np.full(n, 20.0)
    speed[10:20] = np.nan  # 10 unknown frames
    frames = frame_availability(np.full(n, 3.5), np.full(n, 50.0), speed)
    seqs = sequence_availability(frames, segments=[Segment(0, 50, "rain"), Segment(50, 100, "sun")])
    assert seqs[0].category == "rain"
    assert seqs[0].available is None
    assert seqs[0].n_unknown == 10
    assert seqs[1].available is True
    assert seqs[1].n_unknown == 0
    with pytest.raises(CorridorError):
        sequence_availability(frames, segments=[Segment(90, 120)])
    with pytest.raises(CorridorError):
        frame_availability([3.0, 3.0], [10.0], 5.0)


def _naive_longest(flags: list[bool]) -> int:
    best = run = 0
    for f in flags:
        run = run + 1 if f else 0
        best = max(best, run)
    return best


@given(st.lists(st.booleans(), max_size=300))
def test_longest_run_matches_a_loop(flags: list[bool]) -> None:
    assert longest_run(np.array(flags, dtype=bool)) == _naive_longest(flags)


@given(
    st.lists(
        st.tuples(
            st.one_of(st.floats(0.0, 10.0), st.just(math.nan)),
            st.one_of(st.floats(0.0, 200.0), st.just(math.nan)),
            st.one_of(st.floats(0.0, 50.0), st.just(math.nan)),
        ),
        min_size=1,
        max_size=200,
    ),
    st.integers(1, 60),
)
def test_frame_and_sequence_invariants(rows: list[tuple[float, float, float]], window: int) -> None:
    width, length, speed = (np.array(c) for c in zip(*rows, strict=True))
    params = AvailabilityParams(window_frames=window)
    frames = frame_availability(width, length, speed, params)
    # Available exactly when every test passes; unknown frames are never available.
    expected = (
        (width >= 2.0)
        & (width <= 6.0)
        & (length > 0)
        & np.isfinite(speed)
        & (length >= speed * 0.7)
    )
    assert np.array_equal(frames.available, expected)
    assert not np.any(frames.available & ~frames.known)
    assert np.all((frames.reason == "") == frames.available)
    seqs = sequence_availability(frames, params)
    assert sum(s.n_frames for s in seqs) == len(rows)
    assert sum(s.n_available for s in seqs) == int(frames.available.sum())
    for s in seqs:
        assert 0.0 <= s.ratio <= 1.0 or (np.isnan(s.ratio) and s.n_unknown == s.n_frames)
        if s.available is not None:
            assert s.available == (s.longest_outage_frames <= params.max_outage_frames) or (
                s.n_unknown > 0
            )
        if s.n_unknown == 0:
            assert s.available == (s.longest_outage_frames <= 5)


def test_outage_limit_in_seconds_counts_dropped_frames() -> None:
    from superlane_tools.corridor.availability import FrameAvailability, longest_outage_s

    period = 1 / 15
    t = (np.arange(30) * period * 1e9).astype(np.int64)
    avail = np.ones(30, bool)
    avail[10:15] = False  # five frames: the paper's limit, still available
    fa = FrameAvailability(avail, np.ones(30, bool), np.full(30, ""))
    params = AvailabilityParams(window_frames=30, max_outage_s=5 / 15)
    assert sequence_availability(fa, params, None, t)[0].available is True
    avail[15] = False  # six frames: an outage
    fa = FrameAvailability(avail, np.ones(30, bool), np.full(30, ""))
    assert sequence_availability(fa, params, None, t)[0].available is False
    # Dropped frames: every recorded frame is available, but 0.5 s of frames are missing.
    t_drop = np.concatenate([t[:10], t[10:] + int(0.5e9)])
    all_ok = FrameAvailability(np.ones(30, bool), np.ones(30, bool), np.full(30, ""))
    seq = sequence_availability(all_ok, params, None, t_drop)[0]
    assert seq.available is False
    assert seq.longest_outage_s > 0.4
    assert longest_outage_s(np.zeros(30, bool), t, period) == 0.0


def test_unknown_frames_are_never_outage() -> None:
    """A window whose every frame is unknown has no ratio and no outage; known misses count."""
    n = 30
    t = (np.arange(n) * 1e9 / 15).astype(np.int64)
    params = AvailabilityParams(window_frames=n, max_outage_s=5 / 15)
    unknown = frame_availability(np.full(n, 3.5), np.full(n, 40.0), np.full(n, np.nan), params)
    seq = sequence_availability(unknown, params, None, t)[0]
    assert np.isnan(seq.ratio)
    assert seq.available is None
    assert (seq.longest_outage_frames, seq.longest_outage_s) == (0, 0.0)
    speed = np.full(n, np.nan)
    speed[:8] = 30.0  # 8 known frames, too short (30 m/s * 0.7 s = 21 m > 20 m)
    mixed = frame_availability(np.full(n, 3.5), np.full(n, 20.0), speed, params)
    seq = sequence_availability(mixed, params, None, t)[0]
    assert seq.ratio == 0.0
    assert seq.longest_outage_frames == 8  # the known misses only, not the 22 unknown after
    assert seq.longest_outage_s == pytest.approx(8 / 15)
    assert seq.available is False
