"""Quality gates of GNSS fixes: RTK fixed, plain GNSS (degraded truth) or unusable."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.geo.enu import valid_fixes

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

DEGRADED_NOTE = "truth degraded: not RTK"
"""Stated wherever a curvature truth rests on plain (non-RTK) GNSS fixes."""


class FixGrades(NamedTuple):
    """Which fixes the curvature truth uses, and why the others are not.

    Attributes:
        good: (N,) fixes the truth is built from.
        rtk: (N,) fixes that are RTK fixed (status and covariance within the RTK gates).
        reasons: One flag per fix: empty when used as RTK, else why it is excluded or degraded.
        degraded: True when the truth rests on plain GNSS because no fix is RTK fixed.
    """

    good: BoolArray
    rtk: BoolArray
    reasons: list[str]
    degraded: bool


def grade_fixes(
    latitude_deg: FloatArray,
    longitude_deg: FloatArray,
    altitude_m: FloatArray,
    status: FloatArray,
    variance_m2: FloatArray,
    min_status: int = 2,
    max_rtk_var_m2: float = 0.01,
    max_plain_var_m2: float = 25.0,
) -> FixGrades:
    """Grade fixes for the curvature truth.

    A fix is RTK when its position is valid, its ``NavSatStatus.status`` is at least
    ``min_status`` (unknown status counts as passing) and its worse horizontal variance is at
    most ``max_rtk_var_m2`` (unknown covariance passes). When the drive has RTK fixes, only
    those are used. When it has none, plain fixes (status >= 0, variance up to
    ``max_plain_var_m2``) are used and the truth is marked degraded (:data:`DEGRADED_NOTE`):
    its noise floor is then set by metre-level fix noise, not centimetres.

    Args:
        latitude_deg: (N,) latitudes, degrees.
        longitude_deg: (N,) longitudes, degrees.
        altitude_m: (N,) heights, metres.
        status: (N,) ``NavSatStatus.status`` (-1 no fix, 0 fix, 1 SBAS, 2 GBAS/RTK); NaN unknown.
        variance_m2: (N,) worse of the east and north variances, m^2; NaN unknown.
        min_status: Smallest status that counts as RTK.
        max_rtk_var_m2: Largest variance of an RTK fix, m^2.
        max_plain_var_m2: Largest variance of a plain fix used for a degraded truth, m^2.

    Returns:
        The grades.
    """
    usable = valid_fixes(latitude_deg, longitude_deg, altitude_m)
    st = np.asarray(status, dtype=np.float64)
    var = np.asarray(variance_m2, dtype=np.float64)
    known_st = np.isfinite(st)
    known_var = np.isfinite(var)
    with np.errstate(invalid="ignore"):
        status_rtk = ~known_st | (st >= min_status)
        var_rtk = ~known_var | (var <= max_rtk_var_m2)
        plain = usable & (~known_st | (st >= 0)) & (~known_var | (var <= max_plain_var_m2))
    rtk = usable & status_rtk & var_rtk
    degraded = not rtk.any() and bool(plain.any())
    good = plain.copy() if degraded else rtk
    reasons: list[str] = []
    for i in range(st.size):
        if not usable[i]:
            reasons.append("invalid position")
        elif rtk[i]:
            reasons.append("")
        elif degraded and good[i]:
            reasons.append(f"{DEGRADED_NOTE} (status {_status_text(st[i])})")
        elif not status_rtk[i]:
            reasons.append(f"not RTK fixed (status {_status_text(st[i])})")
        else:
            reasons.append(f"covariance {var[i]:.3g} m^2")
    return FixGrades(good, rtk, reasons, degraded)


def _status_text(value: float) -> str:
    return "unknown" if not np.isfinite(value) else str(int(value))
