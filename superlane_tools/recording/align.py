"""Time alignment: sample one stream's values at another stream's times (vectorised)."""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt

from superlane_tools.errors import UsageError

AlignMethod = Literal["nearest", "previous", "linear"]
ALIGN_METHODS: tuple[str, ...] = ("nearest", "previous", "linear")


def align(
    stream_t_ns: npt.ArrayLike,
    values: npt.ArrayLike,
    target_t_ns: npt.ArrayLike,
    method: AlignMethod = "nearest",
    tolerance_ns: int | None = None,
) -> npt.NDArray[np.float64]:
    """Return the stream's values at the target times; NaN where no value applies.

    A target gets NaN when it lies outside ``[stream_t_ns.min(), stream_t_ns.max()]`` or when
    the tolerance is exceeded:

    - ``nearest``: the sample closest in time (ties go to the earlier one); NaN if it is more
      than ``tolerance_ns`` away.
    - ``previous``: the latest sample at or before the target (zero-order hold; among equal
      times the last one); NaN if it is more than ``tolerance_ns`` older.
    - ``linear``: interpolation between the samples bracketing the target; NaN if they are
      more than ``tolerance_ns`` apart (a dropout is not bridged). Exact hits need no partner.

    The stream need not be sorted (it is sorted stably here). Pure numpy: one ``searchsorted``.

    Args:
        stream_t_ns: (N,) sample times of the stream, integer nanoseconds.
        values: (N,) or (N, ...) values of the stream (converted to float64).
        target_t_ns: (M,) times to sample at, integer nanoseconds.
        method: ``nearest``, ``previous`` or ``linear``.
        tolerance_ns: Largest allowed time distance (see above), nanoseconds; None: no limit.

    Returns:
        (M,) or (M, ...) float64 values.

    Raises:
        UsageError: For an unknown method, a negative tolerance or mismatched lengths.
    """
    if method not in ALIGN_METHODS:
        raise UsageError(f"unknown alignment method {method!r}: use one of {ALIGN_METHODS}")
    if tolerance_ns is not None and tolerance_ns < 0:
        raise UsageError(f"tolerance must be >= 0 ns, got {tolerance_ns}")
    t = np.asarray(stream_t_ns, dtype=np.int64).ravel()
    v = np.asarray(values, dtype=np.float64)
    target = np.asarray(target_t_ns, dtype=np.int64).ravel()
    if v.shape[:1] != t.shape:
        raise UsageError(f"{len(t)} stream times but {v.shape[0] if v.ndim else 0} values")
    out = np.full((len(target), *v.shape[1:]), np.nan)
    if len(t) == 0 or len(target) == 0:
        return out
    if np.any(t[1:] < t[:-1]):
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
    limit = np.iinfo(np.int64).max if tolerance_ns is None else int(tolerance_ns)
    inside = (target >= t[0]) & (target <= t[-1])
    # right: index of the first sample after the target; right - 1 is the last at or before it
    right = np.searchsorted(t, target, side="right")
    prev = np.clip(right - 1, 0, len(t) - 1)
    nxt = np.clip(right, 0, len(t) - 1)
    d_prev = target - t[prev]  # >= 0 inside the range
    d_next = t[nxt] - target
    if method == "previous":
        ok = inside & (d_prev <= limit)
        out[ok] = v[prev[ok]]
        return out
    if method == "nearest":
        # the earliest sample of the nearest time: ties between neighbours go to the earlier
        left_first = np.searchsorted(t, t[prev], side="left")
        use_next = (d_next < d_prev) & (right < len(t))
        pick = np.where(use_next, nxt, left_first)
        dist = np.where(use_next, d_next, d_prev)
        ok = inside & (dist <= limit)
        out[ok] = v[pick[ok]]
        return out
    exact = inside & (d_prev == 0)
    span = t[nxt] - t[prev]
    between = inside & ~exact & (right < len(t)) & (span <= limit)
    out[exact] = v[prev[exact]]
    if between.any():
        w = (d_prev[between] / span[between]).astype(np.float64)
        w = w.reshape((-1,) + (1,) * (v.ndim - 1))
        out[between] = (1.0 - w) * v[prev[between]] + w * v[nxt[between]]
    return out
