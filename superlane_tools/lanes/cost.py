"""Costs of the multi-lane fit: road term J1 (Eq. 1), lane term J2 (Eq. 2), J = lambda*J1 + J2.

Points enter as viewing rays from the camera in the vehicle frame, written as ``iq = -dz / (h dx)``
(the inverse flat-ground forward distance ``1 / xf``, 1/m) and ``r = dy / dx`` (lateral slope).
For a candidate slope ``b`` the ray meets the linear road ``z = b x`` of Eq. 10 at
``x = 1 / (iq + b / h)``, ``y = r x`` (metres, from the camera foot) -- exactly Eq. 10's
``x = xf / s``, ``y = yf / s`` with ``s = 1 + b xf / h``, but also defined for rays at or above the
flat horizon (``iq <= 0``), which meet an uphill road. Points whose intersection is behind the
camera or beyond ``max_range_m`` count as out of range.

Beyond the paper, the road may bend vertically: ``z = b x + c x^2`` (``c``: vertical curvature
term, 1/m, the road's vertical curvature is ``2 c``; positive in a sag, negative on a crest). The
ray then meets the road where ``c x^2 / h + (iq + b / h) x = 1``, at the nearer positive root
``x = 2 / (den + sqrt(den^2 + 4 c / h))``, ``den = iq + b / h`` (:func:`road_den`); ``c = 0`` is
the linear road exactly.

Lane parameters are ``theta = (a1, a2, b, a0c[, c])``: heading (rad), half curvature (1/m),
slope (rise over run), the road-centre offset (m) used by J1 only and the optional vertical
curvature term (1/m, 0 when absent). The histogram of Eq. 2 is
*soft-binned*: each residual is split linearly between its two nearest bins, which makes the
entropy continuous in ``theta`` (hard bins make it a staircase that Nelder-Mead cannot descend).

Two backends evaluate the same J: compiled numba kernels (``lanes._kernels``, one pass over the
points, the default) and the pure-numpy reference below (``backend="numpy"``), which the tests
and the benchmark compare against.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from types import ModuleType

    from superlane_tools.lanes.params import FitParams

FloatArray = NDArray[np.float64]
Backend = Literal["numba", "numpy"]
"""Cost backend: compiled numba kernels or the pure-numpy reference."""


def kernels() -> ModuleType:
    """Return the numba kernel module, importing (and compiling) it on first use."""
    from superlane_tools.lanes import _kernels

    return _kernels


class Histogram(NamedTuple):
    """Layout of the offset histogram of Eq. 2.

    Attributes:
        lo_m: Centre of the first bin, metres.
        width_m: Bin width, metres.
        n_bins: Number of bins.
    """

    lo_m: float
    width_m: float
    n_bins: int

    @classmethod
    def symmetric(cls, half_range_m: float, width_m: float) -> Histogram:
        """Return bins of ``width_m`` centred on 0 covering ``[-half_range_m, half_range_m]``."""
        half = round(half_range_m / width_m)
        return cls(-half * width_m, width_m, 2 * half + 1)

    def centres(self) -> FloatArray:
        """Return the bin centres, metres."""
        return self.lo_m + self.width_m * np.arange(self.n_bins, dtype=np.float64)


def soft_histogram(residual_m: FloatArray, hist: Histogram) -> FloatArray:
    """Soft-bin residuals: each value is split between its two nearest bin centres.

    Args:
        residual_m: Residuals ``(..., N)`` in metres; NaN or out-of-range values are dropped.
        hist: Bin layout.

    Returns:
        ``(..., n_bins)`` soft counts; a row sums to the number of in-range values.
    """
    res = np.asarray(residual_m, dtype=np.float64)
    rows = res.reshape(-1, res.shape[-1])
    out = _soft_counts(rows, hist)
    return out.reshape((*res.shape[:-1], hist.n_bins))


def _soft_counts(rows: FloatArray, hist: Histogram) -> FloatArray:
    """Return ``(P, n_bins)`` soft counts of ``(P, N)`` residuals (NaN = out of range)."""
    n_rows = rows.shape[0]
    stride = hist.n_bins + 3
    # Bin k of the layout is slot k+1; slot 0 and slots > n_bins collect the out-of-range values.
    pos = (rows - hist.lo_m) * (1.0 / hist.width_m) + 1.0
    np.nan_to_num(pos, copy=False, nan=0.0)
    np.clip(pos, 0.0, hist.n_bins + 1.0, out=pos)
    idx = pos.astype(np.intp)
    frac = pos - idx
    if n_rows > 1:
        idx += (np.arange(n_rows, dtype=np.intp) * stride)[:, None]
    flat_idx = idx.ravel()
    total = n_rows * stride
    counts = np.bincount(flat_idx, minlength=total).astype(np.float64)
    upper = np.bincount(flat_idx, weights=frac.ravel(), minlength=total)
    soft = counts - upper
    soft[1:] += upper[:-1]
    return soft.reshape(n_rows, stride)[:, 1 : hist.n_bins + 1]


def entropy(counts: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return the Shannon entropy (nats) of each row of histogram counts, and the row totals."""
    c = np.asarray(counts, dtype=np.float64)
    n = c.sum(axis=-1)
    safe_n = np.where(n > 0, n, 1.0)
    p = c / safe_n[..., None]
    logp = np.log(p, where=p > 0, out=np.zeros_like(p))
    h: FloatArray = -(p * logp).sum(axis=-1)
    return h, n


def compensate(
    xf: FloatArray, yf: FloatArray, slope: float | FloatArray, height_m: float
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Map flat-ground points onto the linear road ``z = slope * x`` (paper Eq. 10).

    Args:
        xf: Flat-ground forward distance from the camera foot, metres.
        yf: Flat-ground lateral position (left positive) from the camera foot, metres.
        slope: Road slope ``b`` (rise over run, positive uphill), scalar or broadcastable.
        height_m: Camera height above the road at its foot, metres.

    Returns:
        Corrected ``x``, ``y`` (metres, NaN where the ray misses the road) and the validity mask.
    """
    s = 1.0 + np.asarray(slope, dtype=np.float64) * np.asarray(xf) / height_m
    valid = s > 0
    inv = np.where(valid, 1.0 / np.where(valid, s, 1.0), np.nan)
    return xf * inv, yf * inv, valid


def road_den(den: FloatArray, c_h: float | FloatArray) -> FloatArray:
    """Return ``1 / x`` of rays on the road ``z = b x + c x^2`` from their linear-road value.

    Args:
        den: ``iq + b / h`` of each ray (the inverse distance on the linear road), 1/m.
        c_h: Vertical curvature term over camera height, ``c / h`` (1/m^2), broadcastable.

    Returns:
        ``(den + sqrt(den^2 + 4 c / h)) / 2``, the inverse distance of the nearer intersection;
        ``den`` itself where ``c = 0``; -1 where the ray passes over a crest.
    """
    if np.ndim(c_h) == 0 and float(c_h) == 0.0:
        return den
    disc = den * den + 4.0 * np.asarray(c_h, dtype=np.float64)
    out: FloatArray = np.where(disc >= 0.0, 0.5 * (den + np.sqrt(np.maximum(disc, 0.0))), -1.0)
    return out


def ray_points(
    iq: FloatArray,
    r: FloatArray,
    slope: float,
    height_m: float,
    max_range_m: float,
    vertical_curvature: float = 0.0,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Intersect rays ``(iq, r)`` with the road ``z = slope * x + c * x^2`` (Eq. 10 in ray form).

    Args:
        iq: Inverse flat-ground forward distance ``-dz / (h dx)`` of each ray, 1/m.
        r: Lateral slope ``dy / dx`` of each ray.
        slope: Road slope ``b`` (rise over run).
        height_m: Camera height, metres.
        max_range_m: Farther intersections are invalid, metres.
        vertical_curvature: Vertical curvature term ``c`` (1/m); 0 is the paper's linear road.

    Returns:
        ``x``, ``y`` in metres from the camera foot (NaN where invalid) and the validity mask.
    """
    den = np.asarray(iq, dtype=np.float64) + slope / height_m
    den = road_den(den, vertical_curvature / height_m)
    valid = den >= 1.0 / max_range_m
    x = np.where(valid, 1.0 / np.where(valid, den, 1.0), np.nan)
    return x, r * x, valid


class CostFunction:
    """The combined cost J of Eq. 3 over fixed point sets, evaluated one or many at a time.

    **Entropy per pixel** (``jacobian=True``, a step beyond the paper). Eq. 2's histogram is in
    metres, and a slope ``b > 0`` shrinks every distance (``x = 1 / (iq + b / h)``). Residuals
    that do not come from a line (segmentation noise, a few pixels wide at any range) shrink
    with it, so their entropy falls by the mean ``log`` of the shrinkage: on real masks J2
    alone drives ``b`` to its bound. Adding the binned points' mean ``log(1 / x)`` -- the
    log-Jacobian from image pixels to metres, a pixel at distance ``x`` spanning ``x`` times
    the lateral metres of one at 1 m -- makes J2 the entropy of the residuals per pixel, which
    shrinking the points at one distance does not change (points at many distances keep a
    smaller bias, as their mixture narrows). Parallel lines still sharpen the histogram only
    at the right slope: on rendered TuSimple labels the fit is as accurate as before.

    Attributes:
        n_lane: Number of lane points ``N_l``.
        n_road: Number of road points (0 disables J1).
        evaluations: Number of parameter vectors evaluated so far.
        backend: ``numba`` (compiled kernels) or ``numpy`` (the reference) for ``__call__``
            and ``batch``; ``reference`` and ``reference_batch`` are always numpy.
    """

    def __init__(
        self,
        lane_iq: FloatArray,
        lane_r: FloatArray,
        height_m: float,
        max_range_m: float,
        hist: Histogram,
        kappa: float,
        road_iq: FloatArray | None = None,
        road_r: FloatArray | None = None,
        lambda_road: float = 0.0,
        sigma_d_m: float = 3.0,
        backend: Backend = "numba",
        jacobian: bool = False,
    ) -> None:
        self._iq = np.ascontiguousarray(lane_iq, dtype=np.float64)
        self._r = np.ascontiguousarray(lane_r, dtype=np.float64)
        self._inv_h = 1.0 / height_m
        self._height = height_m
        self._min_den = 1.0 / max_range_m
        self._max_range = max_range_m
        self._hist = hist
        self._kappa = kappa
        self._pos_scale = 1.0 / hist.width_m
        self._pos_shift = 1.0 - hist.lo_m / hist.width_m
        self._top = hist.n_bins + 1.0
        self._stride = hist.n_bins + 3
        self._iq_min = float(self._iq.min()) if self._iq.size else 0.0
        self.n_lane = int(self._iq.size)
        use_road = road_iq is not None and road_r is not None and lambda_road > 0
        self._riq = np.asarray(road_iq if use_road else [], dtype=np.float64)
        self._rr = np.asarray(road_r if use_road else [], dtype=np.float64)
        self.n_road = int(self._riq.size)
        self._lambda = lambda_road
        self._inv_sigma = 1.0 / sigma_d_m
        self._jacobian = 1.0 if jacobian else 0.0
        self.evaluations = 0
        self.backend: Backend = backend
        self.cfg = np.array(
            [
                self._inv_h,
                self._min_den,
                self._pos_scale,
                self._pos_shift,
                float(hist.n_bins),
                kappa,
                lambda_road if self.n_road else 0.0,
                self._inv_sigma,
                self._jacobian,
            ]
        )
        self.scratch = np.zeros(self._stride)

    @property
    def arrays(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Return the lane and road rays ``(iq, r, road_iq, road_r)`` the kernels take."""
        return self._iq, self._r, self._riq, self._rr

    def lane_term(self, a1: float, a2: float, b: float, c: float = 0.0) -> float:
        """Return J2 (Eq. 2) for one parameter set: soft-binned entropy + kappa * N_l / n_l."""
        bh = b * self._inv_h
        den = road_den(self._iq + bh, c * self._inv_h)
        x = 1.0 / den
        pos = x * (self._r - a1 - a2 * x)
        pos *= self._pos_scale
        pos += self._pos_shift
        if c != 0.0 or self._iq_min + bh < self._min_den:
            pos[den < self._min_den] = 0.0
        np.maximum(pos, 0.0, out=pos)
        np.minimum(pos, self._top, out=pos)
        idx = pos.astype(np.intp)
        frac = pos - idx
        stride = self._stride
        counts = np.bincount(idx, minlength=stride)
        upper = np.bincount(idx, weights=frac, minlength=stride)
        soft = counts - upper
        soft[1:] += upper[:-1]
        hist = soft[1 : stride - 2]
        n_in = float(hist.sum())
        if n_in <= 0.0:
            return float(np.log(hist.size) + self._kappa * self.n_lane)
        log_den = 0.0
        if self._jacobian:
            w = binned_mass(pos, idx, frac, self._hist.n_bins)
            log_den = float(np.dot(w, np.log(np.where(w > 0.0, den, 1.0))))
        hist = hist[hist > 0.0]
        p = hist * (1.0 / n_in)
        h = -float(np.dot(p, np.log(p)))
        return h + self._jacobian * log_den / n_in + self._kappa * self.n_lane / n_in

    def road_term(self, a1: float, a2: float, b: float, a0c: float, c: float = 0.0) -> float:
        """Return J1 (Eq. 1): minus the Gaussian closeness of road points to the centre line."""
        if self.n_road == 0:
            return 0.0
        den = road_den(self._riq + b * self._inv_h, c * self._inv_h)
        ok = den >= self._min_den
        x = 1.0 / np.where(ok, den, 1.0)
        d = (x * (self._rr - a1 - a2 * x) - a0c) * self._inv_sigma
        return -float(np.exp(-(d * d))[ok].sum())

    def __call__(self, theta: FloatArray) -> float:
        """Return J = lambda * J1 + J2 for ``theta = (a1, a2, b, a0c[, c])``."""
        if self.backend == "numpy":
            return self.reference(theta)
        self.evaluations += 1
        th = np.ascontiguousarray(theta, dtype=np.float64)
        return float(kernels().total_cost(*self.arrays, th, self.cfg, self.scratch))

    def batch(self, thetas: FloatArray) -> FloatArray:
        """Return J for each row of ``(P, 4)`` or ``(P, 5)`` parameter vectors at once."""
        if self.backend == "numpy":
            return self.reference_batch(thetas)
        th = _rows(thetas)
        self.evaluations += th.shape[0]
        out: FloatArray = kernels().batch_cost(*self.arrays, th, self.cfg, self.scratch)
        return out

    def reference(self, theta: FloatArray) -> float:
        """Return J for one ``theta`` with the pure-numpy reference implementation."""
        self.evaluations += 1
        a1, a2, b, a0c = (float(v) for v in theta[:4])
        c = float(theta[4]) if len(theta) > 4 else 0.0
        cost = self.lane_term(a1, a2, b, c) if self.n_lane else 0.0
        if self.n_road:
            cost += self._lambda * self.road_term(a1, a2, b, a0c, c)
        return cost

    def reference_batch(self, thetas: FloatArray) -> FloatArray:
        """Return J for each row of ``(P, 4)`` or ``(P, 5)`` parameters, vectorised numpy."""
        th = _rows(thetas)
        self.evaluations += th.shape[0]
        a1, a2, b, a0c = (th[:, k : k + 1] for k in range(4))
        c_h = th[:, 4:5] * self._inv_h if th.shape[1] > 4 and np.any(th[:, 4]) else 0.0
        den = road_den(self._iq + b * self._inv_h, c_h)
        ok = den >= self._min_den
        x = 1.0 / np.where(ok, den, 1.0)
        d = x * (self._r - a1 - a2 * x)
        d[~ok] = np.nan
        hist = _soft_counts(d, self._hist)
        h, n_in = entropy(hist)
        safe_n = np.where(n_in > 0, n_in, 1.0)
        if self._jacobian:
            pos = np.clip(np.nan_to_num(self._pos_scale * d + self._pos_shift), 0.0, self._top)
            idx = pos.astype(np.intp)
            w = binned_mass(pos, idx, pos - idx, self._hist.n_bins)
            h = h + (w * np.log(np.where(w > 0.0, den, 1.0))).sum(axis=1) / safe_n
        cost = np.where(
            n_in > 0,
            h + self._kappa * self.n_lane / safe_n,
            np.log(self._hist.n_bins) + self._kappa * self.n_lane,
        )
        if self.n_road:
            denr = road_den(self._riq + b * self._inv_h, c_h)
            okr = denr >= self._min_den
            xr = 1.0 / np.where(okr, denr, 1.0)
            dr = (xr * (self._rr - a1 - a2 * xr) - a0c) * self._inv_sigma
            j1 = -np.where(okr, np.exp(-(dr * dr)), 0.0).sum(axis=1)
            cost = cost + self._lambda * j1
        result: FloatArray = cost.astype(np.float64)
        return result

    def residuals(self, a1: float, a2: float, b: float, c: float = 0.0) -> FloatArray:
        """Return the lane residuals ``y - f(0, a; x)`` on the sloped road (NaN if invalid)."""
        x, y, _ = ray_points(self._iq, self._r, b, self._height, self._max_range, c)
        out: FloatArray = y - x * (a1 + a2 * x)
        return out


class CostSetup(NamedTuple):
    """What every :class:`CostFunction` of one frame shares, besides its points.

    Attributes:
        height_m: Camera height above the road, metres.
        params: The fit's parameters (range, histogram, ``kappa``, ``sigma_d_m``, backend,
            ``pixel_entropy``).
        lambda_road: Weight of J1 (0: lane term only).
    """

    height_m: float
    params: FitParams
    lambda_road: float = 0.0

    def build(
        self,
        lane_iq: FloatArray,
        lane_r: FloatArray,
        road_iq: FloatArray | None = None,
        road_r: FloatArray | None = None,
    ) -> CostFunction:
        """Return J over these lane (and road) rays."""
        p = self.params
        return CostFunction(
            lane_iq,
            lane_r,
            self.height_m,
            p.max_range_m,
            Histogram.symmetric(p.offset_range_m, p.bin_width_m),
            p.kappa,
            road_iq,
            road_r,
            self.lambda_road,
            p.sigma_d_m,
            p.backend,
            p.pixel_entropy,
        )


def binned_mass(
    pos: FloatArray, idx: NDArray[np.intp], frac: FloatArray, n_bins: int
) -> FloatArray:
    """Return the share of each soft-binned point that lands in the histogram's bins.

    ``pos`` is the slot position (bin ``k`` is slot ``k + 1``; slot 0 and ``n_bins + 1`` hold
    what is out of range), ``idx = int(pos)`` and ``frac = pos - idx``; the point puts
    ``1 - frac`` into slot ``idx`` and ``frac`` into slot ``idx + 1``.
    """
    inside = (pos > 0.0) & (pos < n_bins + 1.0)
    lower = np.where(idx >= 1, 1.0 - frac, 0.0)
    upper = np.where(idx < n_bins, frac, 0.0)
    out: FloatArray = np.where(inside, lower + upper, 0.0)
    return out


def _rows(thetas: FloatArray) -> FloatArray:
    """Return parameter vectors as a contiguous ``(P, 4)`` or ``(P, 5)`` float array."""
    th = np.ascontiguousarray(thetas, dtype=np.float64)
    width = th.shape[-1] if th.ndim and th.shape[-1] in (4, 5) else 4
    out: FloatArray = th.reshape(-1, width)
    return out
