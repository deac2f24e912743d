"""Bootstrap deltas and verdicts on sequence sums (pure; the real-run tests are in commands/)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from superlane_tools.errors import UsageError
from superlane_tools.fleet import (
    BETTER,
    KPI_BY_NAME,
    SAME,
    TOO_FEW,
    UNAVAILABLE,
    WORSE,
    BootstrapParams,
    kpi_delta,
    parse_rule,
)

AVAIL = KPI_BY_NAME["availability_frames.super"]
RMSE = KPI_BY_NAME["curvature_rmse_truth.super_path"]
FPS = KPI_BY_NAME["frames_per_s"]
PARAMS = BootstrapParams(n_resamples=999, seed=1)


def test_identical_sequences_give_a_zero_interval() -> None:
    num, den = np.array([10.0, 20.0, 30.0]), np.array([30.0, 30.0, 30.0])
    d = kpi_delta(AVAIL, (num, den), (num, den), True, PARAMS)
    assert (d.delta, d.ci_low, d.ci_high, d.verdict) == (0.0, 0.0, 0.0, SAME)
    assert d.base == pytest.approx(60 / 90)


def test_a_consistent_drop_is_worse_and_a_gain_better() -> None:
    rng = np.random.default_rng(0)
    den = np.full(40, 100.0)
    base = rng.integers(85, 95, 40).astype(float)
    worse = kpi_delta(AVAIL, (base, den), (base - 10, den), True, PARAMS)
    assert worse.verdict == WORSE
    assert worse.ci_high < 0
    assert worse.delta == pytest.approx(-0.1)
    better = kpi_delta(AVAIL, (base - 10, den), (base, den), True, PARAMS)
    assert better.verdict == BETTER
    unpaired = kpi_delta(AVAIL, (base, den), (base[:30] - 10, den[:30]), False, PARAMS)
    assert unpaired.verdict == WORSE
    assert not unpaired.paired


def test_rmse_pools_squared_errors_and_lower_is_better() -> None:
    n = np.full(20, 50.0)
    sse_b = n * 1e-3**2
    d = kpi_delta(RMSE, (sse_b, n), (4 * sse_b, n), True, PARAMS)
    assert d.base == pytest.approx(1e-3)
    assert d.candidate == pytest.approx(2e-3)
    assert d.verdict == WORSE


def test_noise_below_the_relative_margin_is_no_change() -> None:
    den = np.ones(30)
    d = kpi_delta(FPS, (np.full(30, 20.0), den), (np.full(30, 21.0), den), True, PARAMS)
    assert d.ci_low > 0  # significant, but 5 % < the 20 % margin of a timing KPI
    assert d.verdict == SAME


def test_without_truth_the_kpi_is_unavailable_not_zero() -> None:
    zero = np.zeros(5)
    d = kpi_delta(RMSE, (zero, zero), (zero, zero), True, PARAMS)
    assert d.verdict == UNAVAILABLE
    assert math.isnan(d.base)
    one = kpi_delta(
        RMSE, (np.array([1e-6]), np.array([5.0])), (np.array([2e-6]), np.array([5.0])), True, PARAMS
    )
    assert one.verdict == TOO_FEW
    assert math.isnan(one.ci_low)


def test_same_seed_same_interval() -> None:
    rng = np.random.default_rng(3)
    a, b, den = rng.random(25), rng.random(25), np.ones(25)
    first = kpi_delta(AVAIL, (a, den), (b, den), True, PARAMS)
    assert kpi_delta(AVAIL, (a, den), (b, den), True, PARAMS) == first


def test_gate_rules() -> None:
    assert parse_rule("availability_frames.super:2").threshold == 2.0
    assert parse_rule("availability_frames").matches("availability_frames.hough")
    assert parse_rule("all").matches("fit_cost")
    with pytest.raises(UsageError, match="unknown KPI"):
        parse_rule("nope")
    with pytest.raises(UsageError, match="threshold"):
        parse_rule("fit_cost:-1")


def test_many_drives_at_once_agree_with_one_at_a_time() -> None:
    from superlane_tools.fleet.bootstrap import paired_deltas

    rng = np.random.default_rng(5)
    drives = []
    for n, shift in ((6, 0.0), (6, -30.0), (9, 0.0), (1, 0.0), (4, 5.0)):
        den = np.full(n, 100.0)
        base = rng.integers(60, 90, n).astype(float)
        drives.append(((base, den), (np.clip(base + shift + rng.normal(0, 1, n), 0, 100), den)))
    drives.append(((np.zeros(3), np.zeros(3)), (np.zeros(3), np.zeros(3))))
    many = paired_deltas(AVAIL, drives, PARAMS)
    one = [kpi_delta(AVAIL, b, c, True, PARAMS) for b, c in drives]
    assert [d.verdict for d in many] == [d.verdict for d in one]
    assert many[1].verdict == WORSE
    assert many[3].verdict == TOO_FEW
    assert many[5].verdict == UNAVAILABLE
    for a, b in zip(many, one, strict=True):
        assert a.delta == pytest.approx(b.delta, nan_ok=True)
        assert a.n_sequences == b.n_sequences
