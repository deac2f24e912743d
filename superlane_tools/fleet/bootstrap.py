"""Fleet deltas with bootstrap confidence intervals over sequences, and the verdict per KPI.

The unit of resampling is the sequence (a KPI window of a drive): frames within a sequence are
correlated, sequences much less so. Where both runs cover the same sequences the bootstrap is
*paired* (one resample of sequence indices drives both runs, so drive-to-drive variation
cancels); otherwise each run's sequences are resampled independently. Intervals are
percentile intervals of ``scipy.stats.bootstrap`` with a fixed seed, so a comparison is
reproducible; :class:`BootstrapParams` is stated in every output.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.fleet.kpis import Kpi

FloatArray = NDArray[np.float64]

BETTER, WORSE, SAME = "better", "worse", "no significant difference"
UNAVAILABLE, TOO_FEW = "unavailable", "insufficient data"
VERDICTS = (BETTER, WORSE, SAME, UNAVAILABLE, TOO_FEW)
"""``unavailable``: a run has no value (no truth, method not run); ``insufficient data``: fewer
than two sequences carry the KPI in the runs, so no interval can be drawn."""


@dataclass(frozen=True)
class BootstrapParams:
    """How intervals are drawn.

    Attributes:
        confidence: Confidence level of the intervals.
        n_resamples: Bootstrap resamples.
        seed: Seed of the resampling generator.
        method: ``scipy.stats.bootstrap`` method (``percentile``: robust to the constant
            deltas of identical runs, where BCa is undefined).
    """

    confidence: float = 0.95
    n_resamples: int = 2000
    seed: int = 0
    method: str = "percentile"

    def text(self) -> str:
        """Return the one-line statement of the method used in the reports."""
        return (
            f"{self.confidence:.0%} {self.method} bootstrap intervals over sequences "
            f"(scipy.stats.bootstrap, {self.n_resamples} resamples, seed {self.seed}; paired "
            "where both runs cover the same sequences)"
        )


class Delta(NamedTuple):
    """A KPI of the base and the candidate, their difference and its interval.

    ``delta = candidate - base``; ``ci_low``/``ci_high`` NaN when no interval could be drawn.
    """

    base: float
    candidate: float
    delta: float
    ci_low: float
    ci_high: float
    n_sequences: int
    paired: bool
    verdict: str


def _sums(num: FloatArray, den: FloatArray, index: NDArray[Any]) -> tuple[Any, Any]:
    return num[index].sum(axis=-1), den[index].sum(axis=-1)


def _interval(
    statistic: Any, data: tuple[FloatArray, ...], paired: bool, params: BootstrapParams
) -> tuple[float, float]:
    from scipy.stats import bootstrap

    res = bootstrap(
        data,
        statistic,
        n_resamples=params.n_resamples,
        paired=paired,
        vectorized=True,
        confidence_level=params.confidence,
        method=params.method,
        random_state=np.random.default_rng(params.seed),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def kpi_delta(
    kpi: Kpi,
    base: tuple[FloatArray, FloatArray],
    candidate: tuple[FloatArray, FloatArray],
    paired: bool,
    params: BootstrapParams,
) -> Delta:
    """Return the pooled KPI of both runs, the delta, its bootstrap interval and the verdict.

    Args:
        kpi: The KPI (pooling and direction).
        base: ``(num, den)`` per sequence of the base run.
        candidate: The same of the candidate; with ``paired``, the same sequences in the same
            order as ``base``.
        paired: Resample sequences jointly (same sequences in both runs).
        params: Interval settings.
    """
    bn, bd = (np.asarray(a, dtype=np.float64) for a in base)
    cn, cd = (np.asarray(a, dtype=np.float64) for a in candidate)
    if paired:  # a sequence counts where both runs have a value
        keep = (bd > 0) & (cd > 0)
        bn, bd, cn, cd = bn[keep], bd[keep], cn[keep], cd[keep]
    else:
        bn, bd = bn[bd > 0], bd[bd > 0]
        cn, cd = cn[cd > 0], cd[cd > 0]
    b_val = float(kpi.pooled(np.array([bn.sum()]), np.array([bd.sum()]))[0])
    c_val = float(kpi.pooled(np.array([cn.sum()]), np.array([cd.sum()]))[0])
    n = min(len(bd), len(cd))
    if not (math.isfinite(b_val) and math.isfinite(c_val)):
        return Delta(b_val, c_val, math.nan, math.nan, math.nan, n, paired, UNAVAILABLE)
    delta = c_val - b_val
    if n < 2:
        return Delta(b_val, c_val, delta, math.nan, math.nan, n, paired, TOO_FEW)
    if paired:

        def paired_stat(i: NDArray[Any], axis: int = -1) -> Any:
            del axis  # vectorized: resamples along the last axis
            idx = i.astype(np.int64)
            return kpi.pooled(*_sums(cn, cd, idx)) - kpi.pooled(*_sums(bn, bd, idx))

        lo, hi = _interval(paired_stat, (np.arange(n, dtype=np.float64),), True, params)
    else:

        def unpaired_stat(i: NDArray[Any], j: NDArray[Any], axis: int = -1) -> Any:
            del axis
            return kpi.pooled(*_sums(cn, cd, j.astype(np.int64))) - kpi.pooled(
                *_sums(bn, bd, i.astype(np.int64))
            )

        data = (np.arange(len(bd), dtype=np.float64), np.arange(len(cd), dtype=np.float64))
        lo, hi = _interval(unpaired_stat, data, False, params)
    return Delta(b_val, c_val, delta, lo, hi, n, paired, verdict(kpi, b_val, delta, lo, hi))


Pair = tuple[FloatArray, FloatArray]
"""``(num, den)`` per sequence of one run."""


def paired_deltas(
    kpi: Kpi, drives: Sequence[tuple[Pair, Pair]], params: BootstrapParams
) -> list[Delta]:
    """Return :func:`kpi_delta` (paired) for many drives at once.

    Drives with the same number of usable sequences share one vectorised
    ``scipy.stats.bootstrap`` call (the statistic reduces the last axis of ``(drives, n)``
    arrays), so a fleet of hundreds of drives costs a few calls per KPI, not one per drive.
    """
    out: list[Delta | None] = [None] * len(drives)
    groups: dict[int, list[int]] = {}
    kept: list[tuple[FloatArray, ...]] = []
    for i, (base, cand) in enumerate(drives):
        bn, bd, cn, cd = (np.asarray(a, dtype=np.float64) for a in (*base, *cand))
        keep = (bd > 0) & (cd > 0)
        kept.append((bn[keep], bd[keep], cn[keep], cd[keep]))
        if keep.sum() < 2:
            out[i] = kpi_delta(kpi, base, cand, True, params)  # unavailable or too few
        else:
            groups.setdefault(int(keep.sum()), []).append(i)

    def stat(bn: Any, bd: Any, cn: Any, cd: Any, axis: int = -1) -> Any:
        return kpi.pooled(cn.sum(axis=axis), cd.sum(axis=axis)) - kpi.pooled(
            bn.sum(axis=axis), bd.sum(axis=axis)
        )

    from scipy.stats import bootstrap

    for members in groups.values():
        data = tuple(np.stack([kept[i][j] for i in members]) for j in range(4))
        res = bootstrap(
            data,
            stat,
            n_resamples=params.n_resamples,
            paired=True,
            vectorized=True,
            axis=-1,
            confidence_level=params.confidence,
            method=params.method,
            random_state=np.random.default_rng(params.seed),
        )
        lows = np.atleast_1d(res.confidence_interval.low)
        highs = np.atleast_1d(res.confidence_interval.high)
        for row, i in enumerate(members):
            bn, bd, cn, cd = kept[i]
            b_val = float(kpi.pooled(np.array([bn.sum()]), np.array([bd.sum()]))[0])
            c_val = float(kpi.pooled(np.array([cn.sum()]), np.array([cd.sum()]))[0])
            lo, hi = float(lows[row]), float(highs[row])
            delta = c_val - b_val
            out[i] = Delta(
                b_val,
                c_val,
                delta,
                lo,
                hi,
                len(bd),
                True,
                verdict(kpi, b_val, delta, lo, hi) if math.isfinite(delta) else UNAVAILABLE,
            )
    return [d for d in out if d is not None]


def verdict(kpi: Kpi, base: float, delta: float, ci_low: float, ci_high: float) -> str:
    """Return better / worse / no significant difference for a delta and its interval.

    A change counts when the interval excludes 0 and the delta reaches the KPI's
    ``min_relative`` share of the base value (timing KPIs vary between identical runs).
    """
    if not (math.isfinite(ci_low) and math.isfinite(ci_high)):
        return TOO_FEW
    if ci_low <= 0.0 <= ci_high:
        return SAME
    if kpi.min_relative > 0 and abs(delta) < kpi.min_relative * abs(base):
        return SAME
    improved = (delta > 0) == kpi.higher_is_better
    return BETTER if improved else WORSE
