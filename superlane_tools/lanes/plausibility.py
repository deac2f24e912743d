"""Label-free plausibility of fitted lanes: is this what a road seen by this camera looks like?

A segmentation backend that does not suit a camera (another mounting, another optic, a camera
profile far off) still yields lane pixels, and the fit still returns lines; only their geometry
gives it away: an ego lane far narrower or wider than a road lane, a width that jumps from frame
to frame, ego lines that converge or diverge ahead, lines that jump between consecutive frames,
pixels the lines do not explain, few frames with an ego pair at all. A backend can also be
plausible and still not serve the drive: its lines reach too short a way ahead. So the score also
takes the corridor the availability rule judges (``corridor.availability``): how far it reaches
against the length the rule needs, and the share of frames that would be available.
:func:`plausibility` scores fits on those criteria without any label; the per-drive self-check
(``drive.selfcheck``) uses it to choose the segmentation backend.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import NamedTuple

import numpy as np

from superlane_tools.lanes.result import LaneFit


class Reach(NamedTuple):
    """The availability rule's view of each scored frame (same order as the fits).

    Attributes:
        length_m: Corridor length per frame, metres (NaN: no corridor).
        available: Whether the frame would be available (width and length within the rule).
        need_m: The corridor length the rule needs, metres (speed x time gap).
    """

    length_m: Sequence[float]
    available: Sequence[bool]
    need_m: float


@dataclass(frozen=True)
class PlausibilityParams:
    """Thresholds of :func:`plausibility` (metres; shares in ``[0, 1]``).

    Attributes:
        min_width_m: Narrowest plausible ego lane, metres.
        max_width_m: Widest plausible ego lane, metres.
        max_width_std_m: Largest plausible spread (standard deviation) of the ego width, metres.
        max_width_change: Largest change of the ego width over the lines' supported range, as
            a share of the near width (ego lines this far from parallel are not). Real frames
            need the slack: the ego width of TuSimple's frames fitted by the shipped model
            changes by up to 25 % over 50-60 m ahead (road slope changes the fit's road model
            does not follow); a pitch far off makes the lines converge or diverge faster.
        max_step_m: Largest move of an ego line between consecutive frames, metres.
        min_ego_share: Fewest frames with an ego pair for a plausible backend.
        min_share: Fewest ego-pair frames with a width in range, and parallel, for a plausible
            backend.
    """

    min_width_m: float = 2.5
    max_width_m: float = 4.5
    max_width_std_m: float = 0.5
    max_width_change: float = 0.3
    max_step_m: float = 0.3
    min_ego_share: float = 0.5
    min_share: float = 0.6


@dataclass(frozen=True)
class Plausibility:
    """Label-free scores of one backend's fits on a sample of frames.

    Attributes:
        n_frames: Frames scored.
        ego_share: Share of frames with an ego pair.
        width_m: Median ego width, metres (NaN without an ego pair).
        width_in_range: Share of ego-pair frames whose width lies in the plausible range.
        width_std_m: Standard deviation of the ego width, metres (NaN under two pairs).
        parallel: Share of ego-pair frames whose ego lines stay parallel over their range.
        consistency: Share of consecutive frame pairs (both with an ego pair) whose ego lines
            moved at most ``max_step_m`` (NaN when no such pair).
        fit_quality: Mean share of lane points on a fitted line (1 minus the fit residual
            share) over the fitted frames.
        score: Geometric mean of the shares (the stable width counts as one share; with a
            :class:`Reach`, so do the reach share and the available share), in ``[0, 1]``;
            higher is more plausible.
        reason: Why the fits are not plausible ("" when they are).
        reach_m: Median corridor length over the frames with one, metres (NaN without a
            :class:`Reach` or a corridor).
        reach_share: ``min(1, reach_m / need_m)`` (NaN without a :class:`Reach`).
        available: Share of the frames that would be available (NaN without a :class:`Reach`).
    """

    n_frames: int
    ego_share: float
    width_m: float
    width_in_range: float
    width_std_m: float
    parallel: float
    consistency: float
    fit_quality: float
    score: float
    reason: str
    reach_m: float = math.nan
    reach_share: float = math.nan
    available: float = math.nan

    @property
    def plausible(self) -> bool:
        """True when every hard criterion holds."""
        return not self.reason

    def to_dict(self) -> dict[str, float | int | str | bool]:
        """Return the scores as a flat JSON-ready mapping (NaN as None is left to the caller)."""
        out: dict[str, float | int | str | bool] = {
            k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()
        }
        out["plausible"] = self.plausible
        return out

    def summary(self) -> str:
        """Return a one-line summary: score, ego share, width, spread, parallel, consistency."""
        return (
            f"score {self.score:.2f} (ego pair {self.ego_share:.0%}, width {self.width_m:.2f} m "
            f"[{self.width_in_range:.0%} in range, sd {self.width_std_m:.2f} m], parallel "
            f"{self.parallel:.0%}, consistent {_pct(self.consistency)}, fit quality "
            f"{self.fit_quality:.2f}{self._reach_text()})"
        )

    def _reach_text(self) -> str:
        if math.isnan(self.available):
            return ""
        reach = "none" if math.isnan(self.reach_m) else f"{self.reach_m:.1f} m"
        return f", reach {reach}, available {self.available:.0%}"


def _pct(share: float) -> str:
    return "n/a" if math.isnan(share) else f"{share:.0%}"


def _parallel(fit: LaneFit, params: PlausibilityParams) -> bool:
    pair = fit.ego_lines()
    assert pair is not None
    near, far = fit.ego_support_m()
    if not far > near:
        return False
    left, right = pair
    near_width = left.lateral_m(near) - right.lateral_m(near)
    change = left.lateral_m(far) - right.lateral_m(far) - near_width
    return abs(change) <= params.max_width_change * abs(near_width)


def _steps(clips: Sequence[Sequence[LaneFit]], params: PlausibilityParams) -> list[bool]:
    moves = []
    for clip in clips:
        for before, after in pairwise(clip):
            a, b = before.ego_lines(), after.ego_lines()
            if a is None or b is None:
                continue
            step = max(abs(a[0].offset_m - b[0].offset_m), abs(a[1].offset_m - b[1].offset_m))
            moves.append(step <= params.max_step_m)
    return moves


def _reach_shares(reach: Reach | None, n: int) -> tuple[float, float, float]:
    """Return (median reach, reach share, available share); NaNs without ``reach``."""
    if reach is None:
        return math.nan, math.nan, math.nan
    lengths = np.asarray(reach.length_m, dtype=float)
    if lengths.size != n or len(reach.available) != n:
        raise ValueError(f"reach needs one length and one flag per frame ({n})")
    seen = lengths[np.isfinite(lengths)]
    median = float(np.median(seen)) if seen.size else math.nan
    share = 0.0 if not seen.size else min(1.0, max(0.0, median) / max(reach.need_m, 1e-9))
    available = float(np.mean(np.asarray(reach.available, dtype=bool))) if n else 0.0
    return median, share, available


def plausibility(
    clips: Sequence[Sequence[LaneFit]],
    params: PlausibilityParams | None = None,
    reach: Reach | None = None,
) -> Plausibility:
    """Score fits without labels: ego width, its spread, parallel lines, consistency, residual.

    Args:
        clips: Runs of consecutive frames' fits (frame-to-frame consistency is judged within a
            run only); the frames of all runs together give the other scores.
        params: Thresholds (defaults when None).
        reach: The availability rule's corridor per frame (all runs' frames in order): the
            reach share and the available share join the score.

    Returns:
        The scores, with the reason the fits are not plausible ("" when they are): under
        ``min_ego_share`` of the frames with an ego pair, a median width out of range, under
        ``min_share`` of the widths in range, a width spread over ``max_width_std_m``, or under
        ``min_share`` of the pairs parallel.
    """
    p = params or PlausibilityParams()
    fits = [fit for clip in clips for fit in clip]
    n = len(fits)
    pairs = [fit for fit in fits if fit.ego_lines() is not None]
    widths = np.array([fit.lane_width_m for fit in pairs], dtype=float)
    ego_share = len(pairs) / n if n else 0.0
    width = float(np.median(widths)) if widths.size else math.nan
    in_range = (
        float(np.mean((widths >= p.min_width_m) & (widths <= p.max_width_m)))
        if widths.size
        else 0.0
    )
    spread = float(np.std(widths)) if widths.size >= 2 else math.nan
    parallel = float(np.mean([_parallel(fit, p) for fit in pairs])) if pairs else 0.0
    moves = _steps(clips, p)
    consistency = float(np.mean(moves)) if moves else math.nan
    fitted = [fit.quality for fit in fits if fit.ok]
    quality = float(np.mean(fitted)) if fitted else 0.0
    stable = 1.0 if not spread > p.max_width_std_m else p.max_width_std_m / spread
    shares = [ego_share, in_range, stable, parallel, quality]
    if not math.isnan(consistency):
        shares.append(consistency)
    reach_m, reach_share, available = _reach_shares(reach, n)
    if reach is not None:
        shares += [reach_share, available]
    score = float(np.prod(shares) ** (1.0 / len(shares)))
    why = []
    if ego_share < p.min_ego_share:
        why.append(f"ego pair on {ego_share:.0%} of the frames (< {p.min_ego_share:.0%})")
    if pairs and not p.min_width_m <= width <= p.max_width_m:
        why.append(f"ego width {width:.2f} m (not {p.min_width_m}-{p.max_width_m} m)")
    elif pairs and in_range < p.min_share:
        why.append(f"ego width in range on {in_range:.0%} of the pairs (< {p.min_share:.0%})")
    if spread > p.max_width_std_m:
        why.append(f"ego width unstable (sd {spread:.2f} m > {p.max_width_std_m} m)")
    if pairs and parallel < p.min_share:
        why.append(f"ego lines parallel on {parallel:.0%} of the pairs (< {p.min_share:.0%})")
    return Plausibility(
        n,
        ego_share,
        width,
        in_range,
        spread,
        parallel,
        consistency,
        quality,
        score,
        "; ".join(why),
        reach_m,
        reach_share,
        available,
    )
