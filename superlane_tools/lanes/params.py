"""Parameters of the SUPER multi-lane fit (paper section III); the paper's values are defaults."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal

from superlane_tools.lanes.errors import FitParamsError

RoadTerm = Literal["auto", "always", "never"]
Backend = Literal["numba", "numpy"]


@dataclass(frozen=True)
class FitParams:
    """Configuration of :func:`superlane_tools.lanes.fit_frame`.

    Paper values (section III): ``sigma_d_m = 3``, ``kappa = 2``, ``lambda_road = 0.001`` and a
    second-order lane polynomial. The remaining values come from measurements on rendered
    TuSimple train labels (see ``reports/tusimple_oracle.md``).

    Attributes:
        sigma_d_m: Eq. 1 width of the Gaussian road-centre term, metres.
        kappa: Eq. 2 weight of the out-of-range penalty ``kappa * N_l / n_l``.
        lambda_road: Eq. 3 weight of the road term J1.
        order: Lane polynomial order, 1 (straight) or 2 (paper).
        road_term: When to add J1: ``always`` (paper), ``never``, or ``auto`` (only when fewer
            than ``road_term_below`` lane points are available; J1 does not help on clean lane
            points and doubles the cost).
        road_term_below: Lane-point count under which ``auto`` enables J1.
        bin_width_m: Width of the soft-binned offset histogram of Eq. 2, metres.
        offset_range_m: Half-width of the "pre-defined range" of Eq. 2: lane offsets within
            ``+-offset_range_m`` count as ``n_l``, metres.
        min_peak_separation_m: Eq. 4 minimum peak separation (minimum lane width), metres.
        min_prominence_fraction: Eq. 4 minimum peak prominence as a fraction of the lane points.
        min_prominence_points: Lower bound of the minimum prominence, points.
        peak_window_m: Half-width of the window that counts points around a peak and refines
            the offset from their mean residual, metres.
        assign_radius_m: Largest lateral distance of a point from its line to be assigned to it.
        min_line_points: Evidence rule: a line is fitted only when at least this many of the
            frame's usable lane-marking pixels (all of them, not the optimiser's subsample) are
            assigned to it; a histogram peak with fewer (a few stray pixels on a gravel
            shoulder) gives no line. Pixels at the processing size (reprocess: 640 px wide);
            0 turns the rule off. Measured in docs/reprocess.md ("Lane-line evidence").
        slope: Estimate the linear road slope ``b`` (Eq. 10); False fixes ``b = 0`` (flat road).
        slope_bound: Bound on ``|b|`` (rise over run); larger values collapse the view.
        vertical_curvature_bound: Bound on ``|c|`` (1/m) of the vertical curvature term of the
            road ``z = b x + c x^2`` (a step beyond the paper's linear road model, III-B);
            0 (default) fixes ``c = 0``, the paper's model. A vertical curve of radius ``R``
            metres has ``|c| = 1 / (2 R)``: 5e-4 admits crests and sags down to R = 1000 m,
            below the minimum radii of highway vertical curves. Needs ``slope``.
        grid_vertical: Points of the vertical-curvature loss curve in the initial search.
        max_points: Lane points used for peaks and the least-squares refit (deterministic
            subsample above it).
        nm_points: Lane points (a subset of those) that Nelder-Mead evaluates J on; the refit
            restores the precision, so the optimiser only needs to land near the optimum.
        max_road_points: Road points used by J1.
        min_points: Fewer usable lane points than this and the frame is not fitted.
        min_range_m: Nearest forward distance of a usable point, metres.
        max_range_m: Farthest flat-ground forward distance of a usable point, metres.
        heading_bound_rad: Search range ``+-`` of the heading ``a1``, radians.
        curvature_bound: Search range ``+-`` of the curvature ``2 * a2``, 1/m.
        grid_heading: Points of the heading loss curve in the initial search.
        grid_curvature: Points of the curvature loss curve in the initial search.
        grid_slope: Points of the slope loss curve in the initial search.
        max_iterations: Nelder-Mead iteration limit.
        xatol: Nelder-Mead parameter tolerance in units of its initial step (0.01 rad heading,
            0.0005 1/m half curvature, 0.01 slope, 0.5 m road-centre offset).
        fatol: Nelder-Mead cost tolerance (nats).
        pixel_entropy: Measure Eq. 2's entropy per image pixel rather than per metre: add the
            binned points' mean ``log(1 / x)`` (see ``lanes.cost.CostFunction``). Otherwise a
            slope that shrinks the far field lowers the entropy of segmentation noise by
            itself, and real masks drive ``b`` to ``slope_bound``.
        refit: After assigning points to lines, refit shared ``a1, a2, b`` and per-line offsets
            by weighted least squares (a step beyond the paper).
        local_correction: Allow each line a bounded quadratic correction of its own (the
            paper's stated future work for merges and splits).
        local_bound_m: Largest lateral displacement a local correction may add over the line's
            supported range, metres.
        seed: Seed of the deterministic point subsampling.
        backend: ``numba`` (compiled single-pass kernels for the cost, Nelder-Mead and the
            per-point passes) or ``numpy`` (the pure-numpy reference: numpy cost, scipy
            Nelder-Mead); both give the same fit to rounding.
    """

    sigma_d_m: float = 3.0
    kappa: float = 2.0
    lambda_road: float = 0.001
    order: int = 2
    road_term: RoadTerm = "auto"
    road_term_below: int = 150
    bin_width_m: float = 0.1
    offset_range_m: float = 15.0
    min_peak_separation_m: float = 2.4
    min_prominence_fraction: float = 0.003
    min_prominence_points: int = 5
    peak_window_m: float = 0.5
    assign_radius_m: float = 0.8
    min_line_points: int = 20
    slope: bool = True
    slope_bound: float = 0.04
    vertical_curvature_bound: float = 0.0
    grid_vertical: int = 5
    max_points: int = 2000
    nm_points: int = 500
    max_road_points: int = 1000
    min_points: int = 10
    min_range_m: float = 1.0
    max_range_m: float = 200.0
    heading_bound_rad: float = 0.15
    curvature_bound: float = 1.0 / 100.0
    grid_heading: int = 21
    grid_curvature: int = 11
    grid_slope: int = 9
    max_iterations: int = 400
    xatol: float = 0.05
    fatol: float = 1e-3
    pixel_entropy: bool = True
    refit: bool = True
    local_correction: bool = True
    local_bound_m: float = 0.5
    seed: int = 0
    backend: Backend = "numba"

    def __post_init__(self) -> None:
        positive = {
            "sigma_d_m": self.sigma_d_m,
            "bin_width_m": self.bin_width_m,
            "offset_range_m": self.offset_range_m,
            "min_peak_separation_m": self.min_peak_separation_m,
            "peak_window_m": self.peak_window_m,
            "assign_radius_m": self.assign_radius_m,
            "max_range_m": self.max_range_m,
            "xatol": self.xatol,
            "fatol": self.fatol,
        }
        for name, value in positive.items():
            if not value > 0:
                raise FitParamsError(f"{name} must be positive, got {value}")
        if self.order not in (1, 2):
            raise FitParamsError(f"order must be 1 or 2, got {self.order}")
        if self.road_term not in ("auto", "always", "never"):
            raise FitParamsError(f"road_term must be auto, always or never, got {self.road_term}")
        if not 0 <= self.slope_bound < 0.5:
            raise FitParamsError(f"slope_bound must be in [0, 0.5), got {self.slope_bound}")
        if not 0 <= self.vertical_curvature_bound <= 0.01:
            raise FitParamsError(
                f"vertical_curvature_bound must be in [0, 0.01] 1/m, "
                f"got {self.vertical_curvature_bound}"
            )
        if self.vertical_curvature_bound > 0 and not self.slope:
            raise FitParamsError("vertical_curvature_bound > 0 needs slope = true")
        if self.offset_range_m / self.bin_width_m > 20000:
            raise FitParamsError("offset_range_m / bin_width_m exceeds 20000 bins")
        if self.min_range_m < 0 or self.min_range_m >= self.max_range_m:
            raise FitParamsError("need 0 <= min_range_m < max_range_m")
        if min(self.grid_heading, self.grid_curvature, self.grid_slope, self.grid_vertical) < 1:
            raise FitParamsError("loss-curve grids need at least one point each")
        if not 3 <= self.min_points <= min(self.max_points, self.nm_points):
            raise FitParamsError("need 3 <= min_points <= max_points and nm_points")
        if self.backend not in ("numba", "numpy"):
            raise FitParamsError(f"backend must be numba or numpy, got {self.backend}")
        if self.min_line_points < 0:
            raise FitParamsError(f"min_line_points must be >= 0, got {self.min_line_points}")
        if self.kappa < 0 or self.lambda_road < 0 or self.local_bound_m < 0:
            raise FitParamsError("kappa, lambda_road and local_bound_m must be >= 0")

    @property
    def vertical(self) -> bool:
        """Whether the fit estimates the vertical curvature term ``c``."""
        return self.vertical_curvature_bound > 0

    @property
    def n_bins(self) -> int:
        """Number of histogram bins covering ``[-offset_range_m, offset_range_m]``."""
        return round(2 * self.offset_range_m / self.bin_width_m) + 1

    def to_dict(self) -> dict[str, Any]:
        """Return the parameters as a plain mapping (for provenance)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> FitParams:
        """Build parameters from a mapping; unknown keys are an error.

        Raises:
            FitParamsError: If a key is unknown or a value is invalid.
        """
        known = set(cls.__dataclass_fields__)
        unknown = set(data) - known
        if unknown:
            raise FitParamsError(f"unknown fit parameters: {', '.join(sorted(unknown))}")
        try:
            return cls(**data)
        except TypeError as err:
            raise FitParamsError(f"invalid fit parameters: {err}") from err
