"""Lane tracker over travelled distance: a Kalman filter and RTS smoother on SUPER's fits.

One frame's fit is noisy (the pixels of a learned or classical segmentation carry outliers:
vehicles, kerbs, the noisy far range) and sometimes wrong altogether (a collapsed fit with its
slope at the bound, a single line). Production lane trackers therefore filter the lane model
over the distance driven. The state, along the arc length ``s`` (metres) from CAN speed, is

* ``psi``: the vehicle's heading relative to the road, radians (left positive);
* ``d = dpsi/ds``: the lateral-manoeuvre curvature ``l''(s)``, 1/m (random walk);
* ``k``: the road curvature at the vehicle, 1/m;
* ``k1 = dk/ds``: its rate (clothoid), 1/m^2 (random walk);
* ``b``: the road slope ahead relative to the vehicle (Eq. 10, rise over run; random walk).

The vehicle's path curvature is ``k + d``. No yaw rate enters: it would make the path estimate
the IMU's, not the camera's. Each frame measures, from the fit's quadratic over the supported
range ``[x0, x1]`` ahead (midpoint ``m``, half-length ``h``), ``-a1`` and ``2*a2``. A least-squares
quadratic over that range turns the clothoid's cubic ``k1 x^3 / 6`` into
``x^3 ~ (0.6 h^2 - 3 m^2) x + 3 m x^2 + const``, so::

    -a1  = psi - k1 (0.6 h^2 - 3 m^2) / 6
    2 a2 = k + k1 m
    b    = b

which places the curvature measurement at the look-ahead ``m`` and removes the heading bias a
curvature ramp causes. The slope is tracked because a wrong fit usually bends the view: its
slope jumps, and the slope of a road changes slowly along it. The heading measurement does not
wrap at lane changes (all lines are parallel), unlike the lateral offset. Frames are gated
twice: a fit with fewer than two ego lines or its slope at the bound is not a measurement, and
a measurement whose normalised innovation exceeds a chi-square bound is rejected (after
``max_rejections`` in a row the covariance is inflated and the next one accepted, so a real
change cannot lock the track out).
A Rauch-Tung-Striebel pass then smooths the track (reprocessing is offline).

Measurement noise (``TrackerParams.measurement_noise``): ``"fixed"`` uses the same diagonal
``R`` for every frame; ``"fit"`` uses each frame's own covariance of ``(a1, a2, b)`` from the
SUPER refit (``LaneFit.shared_cov``), mapped to ``(-a1, 2*a2, b)``, with its cross terms: a short
or collapsed view gets a large ``R`` and the strong ``2*a2``/``b`` trade-off of one fit is not
read as two independent measurements. That covariance assumes independent pixels, but a
marking's pixels share their error (blur, a worn edge, the road not being exactly quadratic),
so its variances are multiplied by ``fit_noise_inflation`` (about the number of pixels per
independent error: the pixels of one dash or a few metres of line), and each standard deviation
is kept at least ``fit_noise_floor`` times the fixed one, so that a dense but wrong fit cannot
pin the track. The correlations are kept as the fit reports them.

Nothing here reads files: arrays in, arrays out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.errors import ConfigError

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
N_STATE = 5


@dataclass(frozen=True)
class TrackerParams:
    """Noise model and gates of :func:`track_lanes`.

    Attributes:
        curvature_sigma_per_m: Standard deviation of one frame's ``2*a2``, 1/m.
        heading_sigma_rad: Standard deviation of one frame's heading ``a1``, radians.
        manoeuvre_psd: Random-walk density of the lateral-manoeuvre curvature ``d``,
            (1/m)^2 per metre travelled.
        curvature_rate_psd: Random-walk density of the road curvature rate ``k1``,
            (1/m^2)^2 per metre travelled.
        slope_sigma: Standard deviation of one frame's slope ``b`` (rise over run).
        slope_psd: Random-walk density of the slope ``b``, (rise over run)^2 per metre.
        gate_chi2: Largest normalised innovation squared (3 degrees of freedom) accepted.
        max_rejections: After this many rejected measurements in a row the covariance is
            inflated so that the track can follow a real change.
        max_slope_fraction: Fits with ``|b| >= max_slope_fraction * slope_bound`` are not used
            (the optimiser ran into the slope bound: a collapsed view).
        max_step_m: A larger distance between two frames restarts the track, metres.
        smooth: Run the Rauch-Tung-Striebel smoother after the forward filter.
        measurement_noise: ``"fixed"`` (the sigmas above, no correlation) or ``"fit"`` (each
            frame's fit covariance, inflated and floored; frames without one use fixed).
        fit_noise_inflation: Factor on the fit's variances (pixels are not independent).
        fit_noise_floor: Smallest standard deviation as a fraction of the fixed one.
    """

    curvature_sigma_per_m: float = 5e-4
    heading_sigma_rad: float = 5e-3
    manoeuvre_psd: float = 2e-8
    curvature_rate_psd: float = 2e-10
    slope_sigma: float = 3e-3
    slope_psd: float = 3e-7
    gate_chi2: float = 16.3
    max_rejections: int = 10
    max_slope_fraction: float = 0.95
    max_step_m: float = 15.0
    smooth: bool = True
    measurement_noise: str = "fit"
    fit_noise_inflation: float = 25.0
    fit_noise_floor: float = 0.3

    def __post_init__(self) -> None:
        positive = (
            self.curvature_sigma_per_m,
            self.heading_sigma_rad,
            self.manoeuvre_psd,
            self.curvature_rate_psd,
            self.slope_sigma,
            self.slope_psd,
            self.gate_chi2,
            self.max_step_m,
        )
        if not all(v > 0 for v in positive) or self.max_rejections < 0:
            raise ConfigError(
                "tracking noise levels, gate_chi2 and max_step_m must be positive, "
                "max_rejections >= 0"
            )
        if not 0 < self.max_slope_fraction <= 1:
            raise ConfigError("tracking.max_slope_fraction must be in (0, 1]")
        if self.measurement_noise not in ("fixed", "fit"):
            raise ConfigError("tracking.measurement_noise must be 'fixed' or 'fit'")
        if not (self.fit_noise_inflation > 0 and self.fit_noise_floor >= 0):
            raise ConfigError("tracking.fit_noise_inflation must be positive, fit_noise_floor >= 0")


class TrackedLanes(NamedTuple):
    """The tracked lane state at each frame (NaN where there is no track).

    Attributes:
        road_per_m: Road curvature at the vehicle ``k``, 1/m, left positive.
        manoeuvre_per_m: Lateral-manoeuvre curvature ``d = l''(s)``, 1/m.
        path_per_m: Vehicle path curvature ``k + d``, 1/m.
        heading_rad: Vehicle heading relative to the road ``psi``, radians.
        used: Whether the frame's fit was accepted as a measurement.
        gated: Whether the frame's fit was a candidate rejected by the innovation gate.
    """

    road_per_m: FloatArray
    manoeuvre_per_m: FloatArray
    path_per_m: FloatArray
    heading_rad: FloatArray
    used: BoolArray
    gated: BoolArray


def travelled_m(t_ns: NDArray[np.int64], speed_mps: FloatArray) -> FloatArray:
    """Return the distance travelled at each frame from the speed, metres (NaN without speed).

    Trapezoidal integration of the speed over the frame times; gaps in the speed are bridged by
    linear interpolation, frames before the first or after the last speed sample get NaN.
    """
    t = (np.asarray(t_ns, dtype=np.int64) - (int(t_ns[0]) if len(t_ns) else 0)) / 1e9
    v = np.asarray(speed_mps, dtype=np.float64)
    out = np.full(t.shape, np.nan)
    ok = np.isfinite(v)
    if ok.sum() < 2:
        return out
    first, last = np.flatnonzero(ok)[[0, -1]]
    span = slice(first, last + 1)
    vv = np.interp(t[span], t[ok], v[ok])
    steps = 0.5 * (vv[1:] + vv[:-1]) * np.diff(t[span])
    out[span] = np.concatenate([[0.0], np.cumsum(steps)])
    return out


def _transition(step_m: float, p: TrackerParams) -> tuple[FloatArray, FloatArray]:
    """Return ``F`` and ``Q`` of one step of ``step_m`` metres."""
    f = np.eye(N_STATE)
    f[0, 1] = step_m
    f[2, 3] = step_m
    q = np.zeros((N_STATE, N_STATE))
    qd, qk = p.manoeuvre_psd, p.curvature_rate_psd
    s2, s3 = step_m**2, step_m**3
    q[np.ix_([0, 1], [0, 1])] = qd * np.array([[s3 / 3, s2 / 2], [s2 / 2, step_m]])
    q[np.ix_([2, 3], [2, 3])] = qk * np.array([[s3 / 3, s2 / 2], [s2 / 2, step_m]])
    q[4, 4] = p.slope_psd * step_m
    return f, q


def _initial(z: FloatArray, mid_m: float) -> tuple[FloatArray, FloatArray]:
    x = np.array([z[0], 0.0, z[1], 0.0, z[2]])
    p0 = np.diag([0.02**2, 2e-3**2, 3e-3**2, 1e-4**2, 0.01**2])
    # 2*a2 describes the curvature at the look-ahead; its initial rate is unknown.
    p0[2, 2] += (mid_m * 1e-4) ** 2
    return x, p0


def measurement_matrix(mid_m: float, half_m: float) -> FloatArray:
    """Return ``H`` mapping the state to ``(-a1, 2*a2, b)`` for a fit over ``mid -+ half`` m."""
    c1 = 0.6 * half_m**2 - 3.0 * mid_m**2
    return np.array(
        [
            [1.0, 0.0, 0.0, -c1 / 6.0, 0.0],
            [0.0, 0.0, 1.0, mid_m, 0.0],
            [0.0, 0.0, 0.0, 0.0, 1.0],
        ]
    )


def track_lanes(
    s_m: FloatArray,
    heading_rad: FloatArray,
    curvature_per_m: FloatArray,
    slope: FloatArray,
    near_m: FloatArray,
    far_m: FloatArray,
    valid: BoolArray,
    params: TrackerParams | None = None,
    fit_cov: FloatArray | None = None,
    lookahead_m: FloatArray | None = None,
) -> TrackedLanes:
    """Filter and smooth the per-frame fits along the travelled distance.

    Args:
        s_m: Distance travelled at each frame, metres (NaN: no step known; the track restarts).
        heading_rad: The fit's lane heading ``a1`` at the vehicle, radians.
        curvature_per_m: The fit's ``2*a2``, 1/m.
        slope: The fit's road slope ``b`` (rise over run).
        near_m: Nearest forward distance of the fit's supported range, metres.
        far_m: Farthest forward distance of the fit's supported range, metres.
        valid: Frames whose fit may be used as a measurement (ego lines found, slope inside
            its bound).
        params: Noise model and gates.
        fit_cov: Per-frame 3x3 covariance of the fit's ``(a1, a2, b)`` (shape ``(n, 3, 3)``);
            used when ``params.measurement_noise == "fit"``.
        lookahead_m: Per-frame effective look-ahead of the fit's ``2*a2``, metres
            (:func:`superlane_tools.lanes.effective_lookahead`); None or NaN: the middle of
            the supported range.

    Returns:
        The tracked state per frame; frames before the first measurement have NaN.
    """
    p = params or TrackerParams()
    s = np.asarray(s_m, dtype=np.float64)
    n = s.size
    fits = _Fits.of(heading_rad, curvature_per_m, slope, near_m, far_m, valid, lookahead_m)
    sigmas = np.array([p.heading_sigma_rad, p.curvature_sigma_per_m, p.slope_sigma])
    r_fixed = np.diag(sigmas**2)
    use_fit = p.measurement_noise == "fit" and fit_cov is not None
    rec = _Record.empty(n)
    x: FloatArray | None = None
    cov = np.zeros((N_STATE, N_STATE))
    rejections = 0
    for k in range(n):
        x, cov = _predict(rec, k, x, cov, s[k] - s[k - 1] if k else np.nan, p)
        if fits.cand[k]:
            z, h, ahead = fits.measurement(k)
            if x is None:
                x, cov = _initial(z, ahead)
                rec.starts[k] = True
                rec.used[k] = True
                rejections = 0
            else:
                r = fit_noise(fit_cov[k], sigmas, p) if use_fit and fit_cov is not None else r_fixed
                x, cov, rejections = _gated_update(rec, k, (x, cov), z, h, r, rejections, p)
        if x is not None:
            rec.xs_f[k], rec.ps_f[k] = x, cov
    xs = _rts(rec.xs_f, rec.ps_f, rec.xs_p, rec.ps_p, rec.fs, rec.starts) if p.smooth else rec.xs_f
    return TrackedLanes(xs[:, 2], xs[:, 1], xs[:, 2] + xs[:, 1], xs[:, 0], rec.used, rec.gated)


class _Fits(NamedTuple):
    """The per-frame fits as float arrays, and which of them are measurement candidates."""

    a1: FloatArray
    curv: FloatArray
    b: FloatArray
    near: FloatArray
    far: FloatArray
    ahead_m: FloatArray
    cand: BoolArray

    @classmethod
    def of(
        cls,
        heading_rad: FloatArray,
        curvature_per_m: FloatArray,
        slope: FloatArray,
        near_m: FloatArray,
        far_m: FloatArray,
        valid: BoolArray,
        lookahead_m: FloatArray | None,
    ) -> _Fits:
        """The fits of :func:`track_lanes`'s arguments; candidates are finite and valid."""
        a1 = np.asarray(heading_rad, dtype=np.float64)
        curv = np.asarray(curvature_per_m, dtype=np.float64)
        b = np.asarray(slope, dtype=np.float64)
        near, far = np.asarray(near_m, np.float64), np.asarray(far_m, np.float64)
        n = a1.size
        ahead_m = np.full(n, np.nan) if lookahead_m is None else np.asarray(lookahead_m, np.float64)
        cand = (
            np.asarray(valid, dtype=bool)
            & np.isfinite(a1)
            & np.isfinite(curv)
            & np.isfinite(b)
            & np.isfinite(near)
            & np.isfinite(far)
            & (far > near)
        )
        return cls(a1, curv, b, near, far, ahead_m, cand)

    def measurement(self, k: int) -> tuple[FloatArray, FloatArray, float]:
        """Frame ``k``'s measurement ``z = (-a1, 2*a2, b)``, its ``H`` and its look-ahead (m)."""
        near, far, ahead_k = self.near[k], self.far[k], self.ahead_m[k]
        mid, half = 0.5 * (near + far), 0.5 * (far - near)
        ahead = ahead_k if np.isfinite(ahead_k) and ahead_k > 0 else mid
        z = np.array([-self.a1[k], self.curv[k], self.b[k]])
        h = measurement_matrix(mid, half)
        h[1, 3] = ahead  # 2*a2 measures the curvature at the fit's own look-ahead
        return z, h, ahead


@dataclass
class _Record:
    """The forward filter per frame: predicted and filtered states, transitions and flags."""

    xs_f: FloatArray
    ps_f: FloatArray
    xs_p: FloatArray
    ps_p: FloatArray
    fs: FloatArray
    used: BoolArray
    gated: BoolArray
    starts: BoolArray

    @classmethod
    def empty(cls, n: int) -> _Record:
        """A record of ``n`` frames without a track."""
        return cls(
            np.full((n, N_STATE), np.nan),
            np.full((n, N_STATE, N_STATE), np.nan),
            np.full((n, N_STATE), np.nan),
            np.full((n, N_STATE, N_STATE), np.nan),
            np.zeros((n, N_STATE, N_STATE)),
            np.zeros(n, dtype=bool),
            np.zeros(n, dtype=bool),
            np.zeros(n, dtype=bool),
        )


def _predict(
    rec: _Record, k: int, x: FloatArray | None, cov: FloatArray, step: float, p: TrackerParams
) -> tuple[FloatArray | None, FloatArray]:
    """Carry the track over ``step`` metres to frame ``k``, or end it (no step, too long)."""
    restart = x is None or not np.isfinite(step) or not 0 <= step <= p.max_step_m
    if restart:
        x = None
    else:
        assert x is not None
        f, q = _transition(float(step), p)
        x, cov = f @ x, f @ cov @ f.T + q
        rec.fs[k] = f
    if x is not None:
        rec.xs_p[k], rec.ps_p[k] = x, cov
    return x, cov


def _gated_update(
    rec: _Record,
    k: int,
    state: tuple[FloatArray, FloatArray],
    z: FloatArray,
    h: FloatArray,
    r: FloatArray,
    rejections: int,
    p: TrackerParams,
) -> tuple[FloatArray, FloatArray, int]:
    """Update the state with frame ``k``'s measurement unless the innovation gate rejects it.

    Returns:
        The state ``x``, its covariance and the number of rejections in a row.
    """
    x, cov = state
    nu = z - h @ x
    s_cov = h @ cov @ h.T + r
    d2 = float(nu @ np.linalg.solve(s_cov, nu))
    if d2 > p.gate_chi2 and rejections < p.max_rejections:
        rec.gated[k] = True
        return x, cov, rejections + 1
    if d2 > p.gate_chi2:
        cov = cov * 10.0
        s_cov = h @ cov @ h.T + r
    gain = np.linalg.solve(s_cov, h @ cov).T
    x = x + gain @ nu
    cov = (np.eye(N_STATE) - gain @ h) @ cov
    cov = 0.5 * (cov + cov.T)
    rec.used[k] = True
    return x, cov, 0


COV_INDEX = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
"""Upper-triangle entries of the fit covariance of ``(a1, a2, b)`` kept per frame."""
COV_KEYS = tuple(f"super_fit_cov_{i}{j}" for i, j in COV_INDEX)
"""Per-frame column names of those entries (``0``: a1, ``1``: a2, ``2``: b)."""


def cov_from_columns(columns: list[FloatArray]) -> FloatArray:
    """Return ``(n, 3, 3)`` covariances from the :data:`COV_KEYS` columns, in that order."""
    n = len(columns[0])
    out = np.empty((n, 3, 3))
    for col, (i, j) in zip(columns, COV_INDEX, strict=True):
        out[:, i, j] = out[:, j, i] = np.asarray(col, dtype=np.float64)
    return out


SIGN = np.array([-1.0, 2.0, 1.0])
"""Map from the fit's ``(a1, a2, b)`` to the measurement ``(-a1, 2*a2, b)``."""


def fit_noise(cov: FloatArray, fixed_sigmas: FloatArray, p: TrackerParams) -> FloatArray:
    """Return the measurement covariance of ``(-a1, 2*a2, b)`` from a fit's ``(a1, a2, b)`` one.

    The variances are inflated by ``p.fit_noise_inflation`` and each standard deviation kept at
    least ``p.fit_noise_floor * fixed_sigmas``; the fit's correlations are kept. A covariance
    that is not finite or not positive definite gives the fixed diagonal.
    """
    c = np.asarray(cov, dtype=np.float64) * np.outer(SIGN, SIGN)
    var = np.diag(c)
    if not (np.all(np.isfinite(c)) and np.all(var > 0)):
        return np.diag(fixed_sigmas**2)
    sd = np.sqrt(var)
    corr = np.clip(c / np.outer(sd, sd), -0.999, 0.999)
    np.fill_diagonal(corr, 1.0)
    sigma = np.maximum(sd * np.sqrt(p.fit_noise_inflation), p.fit_noise_floor * fixed_sigmas)
    return np.asarray(corr * np.outer(sigma, sigma), dtype=np.float64)


def _rts(
    xs_f: FloatArray,
    ps_f: FloatArray,
    xs_p: FloatArray,
    ps_p: FloatArray,
    fs: FloatArray,
    starts: BoolArray,
) -> FloatArray:
    """Rauch-Tung-Striebel backward pass within each uninterrupted track segment."""
    out = xs_f.copy()
    n = xs_f.shape[0]
    for k in range(n - 2, -1, -1):
        nxt = k + 1
        if starts[nxt] or not np.isfinite(xs_p[nxt, 0]) or not np.isfinite(xs_f[k, 0]):
            continue
        gain = ps_f[k] @ fs[nxt].T @ np.linalg.pinv(ps_p[nxt])
        out[k] = xs_f[k] + gain @ (out[nxt] - xs_p[nxt])
    return out
