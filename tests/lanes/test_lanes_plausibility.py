"""Label-free plausibility scores on constructed fits (``lanes.plausibility``)."""

from __future__ import annotations

import math

import pytest

from superlane_tools.lanes.plausibility import PlausibilityParams, plausibility
from superlane_tools.lanes.result import Lane, LaneFit


def _fit(left: float, right: float, a1_right: float = 0.0, quality: float = 0.95) -> LaneFit:
    """An ego pair at ``left`` / ``right`` metres, seen 5-40 m ahead."""
    lanes = (Lane(left, 0.0, 0.0, 5.0, 40.0), Lane(right, a1_right, 0.0, 5.0, 40.0))
    return LaneFit(a1=0.0, a2=0.0, b=0.0, lanes=lanes, ego_left=0, ego_right=1, quality=quality)


def _clips(fits: list[LaneFit]) -> list[list[LaneFit]]:
    return [fits[i : i + 2] for i in range(0, len(fits), 2)]


def test_a_steady_road_lane_is_plausible_with_a_high_score() -> None:
    fits = [_fit(1.8 + 0.01 * i, -1.7 + 0.01 * i) for i in range(16)]
    p = plausibility(_clips(fits))
    assert p.plausible, p.reason
    assert p.n_frames == 16
    assert p.ego_share == 1.0
    assert p.width_m == pytest.approx(3.5)
    assert p.width_in_range == 1.0
    assert p.width_std_m == pytest.approx(0.0, abs=1e-9)
    assert p.parallel == 1.0
    assert p.consistency == 1.0
    assert p.fit_quality == pytest.approx(0.95)
    assert p.score == pytest.approx(0.95 ** (1 / 6))
    assert "score" in p.summary()
    assert p.to_dict()["plausible"] is True


def test_a_lane_twice_as_wide_as_a_road_lane_is_not_plausible() -> None:
    """A camera height far off scales every width: 7.6 m is no ego lane."""
    p = plausibility(_clips([_fit(3.8, -3.8) for _ in range(16)]))
    assert not p.plausible
    assert "ego width 7.60 m" in p.reason
    assert p.width_in_range == 0.0
    assert p.score == 0.0


def test_converging_ego_lines_are_not_parallel() -> None:
    """A pitch far off makes the lines converge: the width shrinks by 1.4 m over 35 m."""
    p = plausibility(_clips([_fit(1.8, -1.7, a1_right=0.04) for _ in range(16)]))
    assert p.parallel == 0.0
    assert "parallel on 0%" in p.reason


def test_few_ego_pairs_and_unstable_widths_are_named() -> None:
    none = LaneFit(reason="no lines")
    fits = [none] * 10 + [_fit(1.5, -1.5), _fit(2.2, -2.1)] * 3
    p = plausibility(_clips(fits))
    assert p.ego_share == pytest.approx(6 / 16)
    assert "ego pair on 38% of the frames" in p.reason
    wobbly = [_fit(1.75 + d, -1.75 + d) for d in (0, 0)] + [_fit(1.0, -1.6), _fit(2.3, -2.2)] * 4
    q = plausibility([wobbly], PlausibilityParams(max_width_std_m=0.2))
    assert "ego width unstable" in q.reason


def test_lines_that_jump_between_consecutive_frames_lower_the_consistency_only() -> None:
    steady = plausibility(_clips([_fit(1.8, -1.7) for _ in range(16)]))
    jumps = [_fit(1.8 + 0.5 * (i % 2), -1.7 + 0.5 * (i % 2)) for i in range(16)]
    jumpy = plausibility(_clips(jumps))
    assert jumpy.consistency == 0.0
    assert jumpy.score < steady.score
    assert jumpy.plausible  # a jump alone is soft: sampled runs may span a lane change


def test_no_frames_score_zero_and_say_why() -> None:
    p = plausibility([])
    assert p.score == 0.0
    assert math.isnan(p.width_m)
    assert "ego pair on 0%" in p.reason
