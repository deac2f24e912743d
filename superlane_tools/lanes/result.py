"""Results of the multi-lane fit: one ``LaneFit`` per frame holding its ``Lane`` lines."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

Colour = str
"""Marking colour: ``white``, ``yellow`` or ``unknown``."""
Style = str
"""Marking style: ``solid``, ``dashed``, ``double`` or ``unknown``."""


@dataclass(frozen=True)
class Lane:
    """One lane line in the vehicle frame (x forward, y left, metres) on the sloped road.

    The line is ``y(x) = offset_m + a1 * x + a2 * x**2`` on the road surface
    ``z = b * x + c * x**2`` (``b``, ``c`` of the frame), measured from the camera foot.
    ``a1``/``a2`` are the frame's shared values plus this line's bounded local correction
    (equal to them when there is none).

    Attributes:
        offset_m: Lateral offset at ``x = 0``, metres (left positive).
        a1: Heading of this line, radians (positive: pointing left).
        a2: Half curvature of this line, 1/m (curvature ``2 * a2``, positive curving left).
        range_min_m: Nearest forward distance with supporting points, metres.
        range_max_m: Farthest forward distance with supporting points, metres.
        colour: ``white``, ``yellow`` or ``unknown``.
        style: ``solid``, ``dashed``, ``double`` or ``unknown``.
        n_points: Lane pixels assigned to this line.
    """

    offset_m: float
    a1: float
    a2: float
    range_min_m: float
    range_max_m: float
    colour: Colour = "unknown"
    style: Style = "unknown"
    n_points: int = 0

    def lateral_m(self, x_m: float) -> float:
        """Return the line's lateral position (metres, left positive) at forward distance x_m."""
        return self.offset_m + self.a1 * x_m + self.a2 * x_m * x_m


@dataclass(frozen=True)
class LaneFit:
    """The fitted lane model of one frame.

    Attributes:
        a1: Shared heading, radians (positive: lanes point to the left).
        a2: Shared half curvature, 1/m; the curvature is ``2 * a2`` (positive curving left).
        b: Road slope (rise over run, positive uphill) of ``z = b * x + c * x**2`` from the
            camera foot.
        c: Vertical curvature term of the road (1/m; the road's vertical curvature is ``2 c``,
            positive in a sag, negative on a crest); 0 when the fit uses the paper's linear
            road (``FitParams.vertical_curvature_bound = 0``).
        lanes: Lines sorted by offset from left (largest offset) to right.
        ego_left: Index into ``lanes`` of the nearest line left of the camera, or -1.
        ego_right: Index into ``lanes`` of the nearest line right of the camera, or -1.
        road_centre_m: Offset of the road centre line of J1 (metres), NaN if J1 was unused.
        cost: Final value of J (Eq. 3) at the Nelder-Mead optimum.
        iterations: Nelder-Mead iterations.
        evaluations: Cost evaluations (grid points count one each).
        converged: Whether Nelder-Mead met its tolerances.
        fit_time_s: Wall time of the fit, seconds.
        quality: Fraction of usable lane points that lie on a fitted line, in ``[0, 1]``.
        reason: Empty for a normal fit, else why the frame was not (fully) fitted:
            ``no lane pixels``, ``all road``, ``too few points``, ``no lines``, ``one line``.
        n_points: Usable lane points (flat-ground projection valid and within range).
        shared_cov: 3x3 covariance of ``(a1, a2, b)`` (radians, 1/m, rise over run) from the
            least-squares refit, the per-line offsets (and ``c``) as nuisance parameters and the
            pixels assumed independent (so optimistic: inflate it before use); NaN where no
            refit ran or was kept, or for a parameter the refit did not estimate.
    """

    a1: float = math.nan
    a2: float = math.nan
    b: float = math.nan
    c: float = 0.0
    lanes: tuple[Lane, ...] = ()
    ego_left: int = -1
    ego_right: int = -1
    road_centre_m: float = math.nan
    cost: float = math.nan
    iterations: int = 0
    evaluations: int = 0
    converged: bool = False
    fit_time_s: float = 0.0
    quality: float = 0.0
    reason: str = ""
    n_points: int = 0
    extras: dict[str, float] = field(default_factory=dict, compare=False, repr=False)
    shared_cov: NDArray[np.float64] = field(
        default_factory=lambda: np.full((3, 3), math.nan), compare=False, repr=False
    )

    @property
    def curvature(self) -> float:
        """Shared curvature ``2 * a2`` in 1/m (positive curving left)."""
        return 2.0 * self.a2

    @property
    def ok(self) -> bool:
        """True when at least one line was fitted."""
        return bool(self.lanes)

    @property
    def offsets(self) -> list[float]:
        """Lane offsets (metres, left positive), in ``lanes`` order."""
        return [lane.offset_m for lane in self.lanes]

    @property
    def lane_width_m(self) -> float:
        """Width of the ego lane (left minus right line offset), metres; NaN if unknown."""
        if self.ego_left < 0 or self.ego_right < 0:
            return math.nan
        return self.lanes[self.ego_left].offset_m - self.lanes[self.ego_right].offset_m

    def ego_lines(self) -> tuple[Lane, Lane] | None:
        """Return the ego lane's left and right lines, or None when the fit has no ego pair."""
        if not self.ok or self.ego_left < 0 or self.ego_right < 0:
            return None
        return self.lanes[self.ego_left], self.lanes[self.ego_right]

    def ego_support_m(self) -> tuple[float, float]:
        """Return the ego lines' common supported range ``(near, far)`` ahead, metres (NaN: none).

        ``far <= near`` when the two lines' ranges do not overlap.
        """
        pair = self.ego_lines()
        if pair is None:
            return math.nan, math.nan
        left, right = pair
        return max(left.range_min_m, right.range_min_m), min(left.range_max_m, right.range_max_m)

    def plausible(self, max_slope: float) -> bool:
        """Whether the fit has both ego lines, a finite curvature and ``|b| < max_slope``.

        A slope at the optimiser's bound means the view has collapsed: such a fit must not seed
        the next frame's warm start nor enter the lane tracker.
        """
        return (
            self.ego_lines() is not None
            and abs(self.b) < max_slope
            and math.isfinite(self.curvature)
        )

    def trackable(self, max_slope: float) -> bool:
        """Whether the lane tracker may use the fit: plausible, with a common ego-line range."""
        near, far = self.ego_support_m()
        return far > near and self.plausible(max_slope)

    def lane_grid(self) -> tuple[float, float, float]:
        """Return the lane-grid centre offset and lane width (m), and the fit's look-ahead (m).

        The centre offset is the circular mean, with period one lane width, of every fitted
        line's offset shifted by half a width (nearer lines weigh more): it needs no choice of
        ego pair, so it stays continuous while the vehicle straddles a line during a lane change.
        The look-ahead is where the fit's ``2*a2`` measures the road: the effective look-ahead
        of its weighted design (``extras["lookahead_m"]``, :mod:`superlane_tools.lanes.
        fit_lookahead`), else the middle of the ego lines' common support. All three are NaN
        without an ego pair; the first two also when the width is <= 1 m.
        """
        if self.ego_lines() is None:
            return math.nan, math.nan, math.nan
        near, far = self.ego_support_m()
        width = self.lane_width_m
        ahead = 0.5 * (near + far) if far > near else math.nan
        effective = self.extras.get("lookahead_m", math.nan)
        if far > near and math.isfinite(effective) and effective > 0:
            ahead = effective
        if width <= 1.0:
            return math.nan, math.nan, ahead
        offsets = np.array([lane.offset_m for lane in self.lanes]) - 0.5 * width
        weights = np.exp(-np.abs(offsets) / width)
        phase = np.angle(np.sum(weights * np.exp(2j * np.pi * offsets / width)))
        return float(width * phase / (2 * np.pi)), width, ahead
