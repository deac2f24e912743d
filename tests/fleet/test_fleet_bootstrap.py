"""Intervals over drives, the sign-flip test, verdicts, Holm, the gate (pure; runs: commands/)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from superlane_tools.errors import UsageError
from superlane_tools.fleet import (
    BETTER,
    EQUIVALENT,
    INCONCLUSIVE,
    KPI_BY_NAME,
    MIN_DRIVES,
    TOO_FEW,
    UNAVAILABLE,
    WORSE,
    BootstrapParams,
    drive_delta,
    holm,
    judge,
    parse_rule,
)
from superlane_tools.fleet.bootstrap import (
    interval,
    resample_counts,
    sign_flip_p,
    sign_flips,
    studentized,
)
from superlane_tools.fleet.verdicts import gate_flags

AVAIL = KPI_BY_NAME["availability_frames.super"]
RMSE = KPI_BY_NAME["curvature_rmse_truth.super_path"]
FPS = KPI_BY_NAME["frames_per_s"]
PARAMS = BootstrapParams(n_resamples=999, seed=1)


def _fleets(
    rng: np.random.Generator, n_fleets: int, m: int, shift: float = 0.0
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Availability sums of ``m`` drives: drive levels, a drive x run effect, binomial frames."""
    den = rng.integers(500, 3000, (n_fleets, m)).astype(float)
    level = rng.normal(2.0, 0.8, (n_fleets, m))
    pb = 1 / (1 + np.exp(-(level + rng.normal(0, 0.3, (n_fleets, m)))))
    pc = 1 / (1 + np.exp(-(level + rng.normal(0, 0.3, (n_fleets, m)) + shift)))
    nb = rng.binomial(den.astype(int), pb).astype(float)
    nc = rng.binomial(den.astype(int), pc).astype(float)
    return (nb, den), (nc, den)


@pytest.mark.parametrize("m", [10, 30])
def test_no_change_is_flagged_at_most_about_five_percent_of_the_time(m: int) -> None:
    rng = np.random.default_rng(7)
    base, cand = _fleets(rng, 600, m)
    s = studentized(base, cand, "none", resample_counts(m, 499, rng))
    lo, hi, _ = interval(s, 0.95)
    p = sign_flip_p(base, cand, "none", sign_flips(m, 499, rng))
    excludes = np.mean((lo > 0) | (hi < 0))
    significant = np.mean(p < 0.05)
    # 600 fleets: a rate of 5 % lies in [3.3 %, 6.9 %] with 95 % probability
    assert 0.02 < excludes < 0.08, excludes
    assert significant < 0.075, significant


def test_a_percentile_interval_over_drives_would_be_too_narrow() -> None:
    """The reason for the studentized interval: percentiles of 10 drives cover too little."""
    rng = np.random.default_rng(8)
    base, cand = _fleets(rng, 600, 10)
    s = studentized(base, cand, "none", resample_counts(10, 499, rng))
    p_lo, p_hi = np.quantile(s.d_star, [0.025, 0.975], axis=1)
    lo, hi, _ = interval(s, 0.95)
    assert np.mean((p_lo > 0) | (p_hi < 0)) > np.mean((lo > 0) | (hi < 0))


def test_the_sign_flip_test_is_exact_and_cannot_reach_five_percent_on_five_drives() -> None:
    patterns, exact = sign_flips(5, 999, np.random.default_rng(0))
    assert exact
    assert patterns.shape == (32, 5)
    den = np.full(5, 100.0)
    p = sign_flip_p(
        (np.full(5, 90.0), den), (np.full(5, 50.0) + np.arange(5), den), "none", (patterns, exact)
    )
    assert p[0] == pytest.approx(2 / 32)  # all five drives worse: still not below 5 %
    patterns, exact = sign_flips(12, 999, np.random.default_rng(0))
    assert not exact
    assert patterns.shape == (999, 12)


def test_a_consistent_drop_on_ten_drives_is_worse_and_a_gain_better() -> None:
    rng = np.random.default_rng(0)
    (nb, den), _ = _fleets(rng, 1, 12)
    nb, den = nb[0], den[0]
    drop = nb - den * rng.uniform(0.08, 0.12, 12)
    worse = drive_delta(AVAIL, (nb, den), (drop, den), PARAMS)
    assert worse.verdict == WORSE
    assert worse.ci_high < 0
    assert worse.p_value < 0.01
    assert worse.n_drives == 12
    assert worse.delta == pytest.approx(drop.sum() / den.sum() - nb.sum() / den.sum())
    better = drive_delta(AVAIL, (drop, den), (nb, den), PARAMS)
    assert better.verdict == BETTER


def test_a_small_change_within_the_margin_is_equivalent() -> None:
    rng = np.random.default_rng(1)
    den = np.full(30, 1000.0)
    nb = rng.integers(850, 950, 30).astype(float)
    d = drive_delta(AVAIL, (nb, den), (nb - rng.integers(0, 10, 30), den), PARAMS)
    assert d.ci_high < 0  # significant, but well inside the 2 pp margin
    assert d.verdict == EQUIVALENT
    assert d.margin == pytest.approx(0.02)
    wide = drive_delta(AVAIL, (nb, den), (nb, den), PARAMS, margin=0.0)
    assert wide.verdict == EQUIVALENT  # zero spread, no change: the same on every drive
    noisy = drive_delta(AVAIL, (nb, den), (rng.permutation(nb), den), PARAMS)
    assert noisy.verdict in (EQUIVALENT, INCONCLUSIVE)


def test_rmse_pools_squared_errors_and_lower_is_better() -> None:
    rng = np.random.default_rng(2)
    n = np.full(12, 50.0)
    sse_b = n * (1e-3 * rng.uniform(0.8, 1.2, 12)) ** 2
    d = drive_delta(RMSE, (sse_b, n), (4 * sse_b * rng.uniform(0.9, 1.1, 12), n), PARAMS)
    assert d.base == pytest.approx(math.sqrt(sse_b.sum() / n.sum()))
    assert d.verdict == WORSE


def test_zero_spread_says_so_instead_of_an_interval() -> None:
    den = np.full(10, 100.0)
    same = drive_delta(AVAIL, (np.full(10, 90.0), den), (np.full(10, 90.0), den), PARAMS)
    assert same.note.startswith("zero spread")
    assert (same.delta, same.p_value, same.verdict) == (0.0, 1.0, EQUIVALENT)
    shifted = drive_delta(AVAIL, (np.full(10, 90.0), den), (np.full(10, 80.0), den), PARAMS)
    assert shifted.note.startswith("zero spread")
    assert shifted.verdict == WORSE  # the same -10 pp on every one of 10 drives
    assert shifted.p_value == 0.0


def test_too_few_drives_give_no_verdict() -> None:
    assert MIN_DRIVES == 10
    den = np.full(MIN_DRIVES - 1, 100.0)
    d = drive_delta(AVAIL, (np.full(9, 90.0), den), (np.arange(9.0) + 40, den), PARAMS)
    assert d.verdict == TOO_FEW
    assert d.n_drives == 9
    assert math.isnan(d.ci_low)
    assert d.delta < 0  # the change is still shown


def test_without_truth_the_kpi_is_unavailable_not_zero() -> None:
    zero = np.zeros(12)
    d = drive_delta(RMSE, (zero, zero), (zero, zero), PARAMS)
    assert d.verdict == UNAVAILABLE
    assert math.isnan(d.base)


def test_frames_per_s_has_a_relative_margin() -> None:
    den = np.ones(12)
    rng = np.random.default_rng(3)
    base = np.full(12, 20.0) + rng.normal(0, 0.1, 12)
    d = drive_delta(FPS, (base, den), (base * 1.05, den), PARAMS)
    assert d.margin == pytest.approx(0.2 * base.mean())
    assert d.verdict == EQUIVALENT  # 5 % faster is inside 20 %: timing noise


def test_same_seed_same_interval() -> None:
    rng = np.random.default_rng(3)
    (nb, den), (nc, _) = _fleets(rng, 1, 15)
    first = drive_delta(AVAIL, (nb[0], den[0]), (nc[0], den[0]), PARAMS)
    assert drive_delta(AVAIL, (nb[0], den[0]), (nc[0], den[0]), PARAMS) == first


def test_holm_steps_down() -> None:
    p = np.array([0.01, 0.04, 0.03, 0.2, np.nan])
    # sorted 0.01 <= 0.05/4, 0.03 > 0.05/3: stop
    assert holm(p, 0.05).tolist() == [True, False, False, False, False]
    assert holm(np.array([0.001, 0.02, 0.04]), 0.05).tolist() == [True, True, True]
    assert holm(np.array([0.04]), 0.05).tolist() == [True]
    assert not holm(np.array([0.06]), 0.05).any()


def test_judge_and_gate_flags() -> None:
    assert judge(AVAIL, 0.02, -0.01, 0.01) == EQUIVALENT
    assert judge(AVAIL, 0.02, -0.06, -0.001) == WORSE
    assert judge(AVAIL, 0.02, -0.06, -0.001, significant=False) == INCONCLUSIVE
    assert judge(AVAIL, 0.02, -0.06, 0.04) == INCONCLUSIVE
    assert judge(RMSE, 1e-4, 2e-4, 5e-4) == WORSE  # lower is better
    # KPIs: significantly worse past the margin; not significant past it; inside the margin
    fails, undecided = gate_flags(
        np.array([0.001, 0.3, 0.001]),
        np.array([-0.019, -0.01, -0.005]),
        np.array([-0.06, -0.04, -0.008]),  # the "-1.9 pp, [-6, -0.1] pp" first
        np.array([0.02, 0.02, 0.02]),
        0.05,
    )
    assert fails.tolist() == [True, False, False]
    assert undecided.tolist() == [False, True, False]


def test_gate_rules() -> None:
    assert parse_rule("availability_frames.super:2").margin == 2.0
    assert parse_rule("availability_frames.super").margin is None
    assert parse_rule("availability_frames").matches("availability_frames.hough")
    assert parse_rule("all").matches("fit_cost")
    assert parse_rule("coverage").matches("coverage.fit")
    with pytest.raises(UsageError, match="unknown KPI"):
        parse_rule("nope")
    with pytest.raises(UsageError, match="margin"):
        parse_rule("fit_cost:-1")
