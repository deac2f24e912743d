"""A drive's per-frame results as one typed record, gathered while the frames stream.

:class:`DriveRecorder` takes each finished frame in order, streams its rows into the per-frame
tables (frames, lanes, corridor, baseline) and keeps the few numbers per frame that the tables
after the pass need; :meth:`DriveRecorder.record` returns them as a frozen :class:`DriveFrames`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.drive.stages import Finished
from superlane_tools.lanes.tracker import COV_INDEX
from superlane_tools.reporting.layout import STAGES

FloatArray = NDArray[np.float64]
BLOCK_ROWS = 256
"""Rows a record's buffers hold before they first grow."""


class _Rows:
    """Fixed-width rows appended one at a time into a growing array (amortised doubling).

    A drive's per-frame numbers as compact array rows (8 bytes a value) instead of Python tuples
    of float objects (about 30 bytes a value): memory that grows with the drive's length.
    """

    def __init__(self, width: int, dtype: type = np.float64) -> None:
        self._data: NDArray[Any] = np.empty((BLOCK_ROWS, width), dtype=dtype)
        self._n = 0

    def append(self, row: tuple[Any, ...]) -> None:
        """Add one row."""
        if self._n == self._data.shape[0]:
            grown = np.empty((2 * self._n, self._data.shape[1]), dtype=self._data.dtype)
            grown[: self._n] = self._data
            self._data = grown
        self._data[self._n] = row
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def array(self) -> NDArray[Any]:
        """Return a copy of the rows so far, ``(n, width)``."""
        return self._data[: self._n].copy()


@dataclass(frozen=True)
class Corridors:
    """Corridor width and length per frame (metres, NaN where not measured) of each method.

    Attributes:
        super_width_m: From the SUPER fit's ego lines.
        super_length_m: Reach of the shorter SUPER ego line.
        net_width_m: From the ego-corridor network's three-frame mean.
        net_length_m: Length of the network's corridor.
        hough_width_m: From the Hough baseline (NaN where it failed).
        hough_length_m: Range of the Hough baseline.
    """

    super_width_m: FloatArray
    super_length_m: FloatArray
    net_width_m: FloatArray
    net_length_m: FloatArray
    hough_width_m: FloatArray
    hough_length_m: FloatArray

    def by_method(self) -> dict[str, tuple[FloatArray, FloatArray]]:
        """Return method -> (width, length), in ``reporting.drive_tables.METHODS`` order."""
        return {
            "super": (self.super_width_m, self.super_length_m),
            "corridor_net": (self.net_width_m, self.net_length_m),
            "hough": (self.hough_width_m, self.hough_length_m),
        }


@dataclass(frozen=True)
class FitSeries:
    """The SUPER fit per frame (NaN where the frame has no fit).

    Attributes:
        curvature_per_m: ``2 a2``, 1/m, left positive.
        heading_rad: ``a1``, rad.
        slope: Road slope ``b``.
        centre_m: Lane-grid centre offset, m (see :meth:`LaneFit.lane_grid`).
        lane_width_m: Ego lane width, m.
        lookahead_m: Where the fit's 2*a2 measures the road (its effective look-ahead), m.
        near_m: Near end of that range, m.
        far_m: Far end of that range, m.
        left_m: Ego left line's lateral offset at ``x = 0`` (camera foot), m, left positive.
        right_m: Ego right line's lateral offset at ``x = 0``, m.
        trackable: Whether the lane tracker may use the fit.
        cov: ``(n, 3, 3)`` covariance of ``(a1, a2, b)`` (NaN without a fit).
    """

    curvature_per_m: FloatArray
    heading_rad: FloatArray
    slope: FloatArray
    centre_m: FloatArray
    lane_width_m: FloatArray
    lookahead_m: FloatArray
    near_m: FloatArray
    far_m: FloatArray
    left_m: FloatArray
    right_m: FloatArray
    trackable: NDArray[np.bool_]
    cov: FloatArray


@dataclass(frozen=True)
class DriveFrames:
    """A drive's per-frame results, one entry per camera frame in log-time order.

    Attributes:
        t_ns: Log times of the frames, ns.
        decoded: Whether each frame's image could be decoded.
        corridors: Corridor geometry of each method.
        fit: The SUPER fit series.
        stage_s: ``(n, len(STAGES))`` wall seconds per stage (``reporting.layout.STAGES``).
        stage_cpu_s: The same in thread CPU seconds.
    """

    t_ns: NDArray[np.int64]
    decoded: NDArray[np.bool_]
    corridors: Corridors
    fit: FitSeries
    stage_s: FloatArray
    stage_cpu_s: FloatArray

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    def frame_rate_hz(self, default: float = 15.0) -> float:
        """Return the median frame rate, Hz (``default`` with fewer than two distinct times)."""
        steps = np.diff(self.t_ns)[np.diff(self.t_ns) > 0]  # frames may share log times
        return 1e9 / float(np.median(steps)) if steps.size else default

    def stage_totals(self) -> dict[str, float]:
        """Return seconds per stage summed over frames: ``<stage>`` wall, ``cpu_<stage>`` CPU."""
        wall, cpu = self.stage_s.sum(axis=0), self.stage_cpu_s.sum(axis=0)
        out = {s: float(wall[k]) for k, s in enumerate(STAGES)}
        out.update({f"cpu_{s}": float(cpu[k]) for k, s in enumerate(STAGES)})
        return out


def no_camera_frames(t_ns: np.ndarray) -> DriveFrames:
    """Return a drive record at evaluation times ``t_ns`` with no image result (all NaN).

    The arrays are shared and read-only: nothing writes into a record.
    """
    n = t_ns.size
    nan = np.full(n, np.nan)
    nan.flags.writeable = False
    return DriveFrames(
        t_ns=t_ns,
        decoded=np.zeros(n, dtype=bool),
        corridors=Corridors(nan, nan, nan, nan, nan, nan),
        fit=FitSeries(
            curvature_per_m=nan,
            heading_rad=nan,
            slope=nan,
            centre_m=nan,
            lane_width_m=nan,
            lookahead_m=nan,
            near_m=nan,
            far_m=nan,
            left_m=nan,
            right_m=nan,
            trackable=np.zeros(n, dtype=bool),
            cov=np.full((n, 3, 3), np.nan),
        ),
        stage_s=np.zeros((n, len(STAGES))),
        stage_cpu_s=np.zeros((n, len(STAGES))),
    )


_COLUMNS = (
    "super_w",
    "super_l",
    "net_w",
    "net_l",
    "hough_w",
    "hough_l",
    "curv",
    "a1",
    "b",
    "centre",
    "width",
    "ahead",
    "near",
    "far",
    "left",
    "right",
)


class DriveFramesBuilder:
    """Gathers a drive's :class:`DriveFrames` from its finished frames, taken in order.

    Args:
        max_slope: Largest plausible ``|b|`` (see :meth:`LaneFit.plausible`).
    """

    def __init__(self, max_slope: float) -> None:
        self._max_slope = max_slope
        self._t = _Rows(1, np.int64)
        self._flags = _Rows(2, np.bool_)  # decoded, trackable
        self._values = _Rows(len(_COLUMNS))
        self._cov = _Rows(len(COV_INDEX))
        self._stage = _Rows(len(STAGES))
        self._stage_cpu = _Rows(len(STAGES))

    def add(self, done: Finished) -> None:
        """Take one finished frame (frames come in order)."""
        prep, fit = done.prepared, done.fit
        h = prep.hough
        hough_ok = h is not None and h.ok
        centre, width, ahead = fit.lane_grid()
        near, far = fit.ego_support_m()
        ego = fit.ego_lines()
        self._t.append((prep.log_time_ns,))
        self._flags.append((not prep.error, fit.trackable(self._max_slope)))
        self._values.append(
            (
                done.super_corridor.width_m,
                done.super_corridor.length_m,
                done.net_corridor.width_m,
                done.net_corridor.length_m,
                h.width_m if h is not None and hough_ok else math.nan,
                h.range_m if h is not None and hough_ok else math.nan,
                fit.curvature if fit.ok else math.nan,
                fit.a1 if fit.ok else math.nan,
                fit.b if fit.ok else math.nan,
                centre,
                width,
                ahead,
                near,
                far,
                ego[0].offset_m if ego else math.nan,
                ego[1].offset_m if ego else math.nan,
            )
        )
        cov = fit.shared_cov if fit.ok else None
        self._cov.append(
            tuple(float(cov[i, j]) if cov is not None else math.nan for i, j in COV_INDEX)
        )
        self._stage.append(tuple(prep.seconds.get(s, 0.0) for s in STAGES))
        self._stage_cpu.append(tuple(prep.cpu_seconds.get(s, 0.0) for s in STAGES))

    def frames(self) -> DriveFrames:
        """Return the frames taken so far as a :class:`DriveFrames`."""
        n = len(self._t)
        values = self._values.array()
        col = {name: values[:, k].copy() for k, name in enumerate(_COLUMNS)}
        upper = self._cov.array()
        cov = np.empty((n, 3, 3))
        for k, (i, j) in enumerate(COV_INDEX):
            cov[:, i, j] = cov[:, j, i] = upper[:, k]
        flags = self._flags.array()
        return DriveFrames(
            t_ns=self._t.array()[:, 0].copy(),
            decoded=flags[:, 0].copy(),
            corridors=Corridors(
                col["super_w"],
                col["super_l"],
                col["net_w"],
                col["net_l"],
                col["hough_w"],
                col["hough_l"],
            ),
            fit=FitSeries(
                curvature_per_m=col["curv"],
                heading_rad=col["a1"],
                slope=col["b"],
                centre_m=col["centre"],
                lane_width_m=col["width"],
                lookahead_m=col["ahead"],
                near_m=col["near"],
                far_m=col["far"],
                left_m=col["left"],
                right_m=col["right"],
                trackable=flags[:, 1].copy(),
                cov=cov,
            ),
            stage_s=self._stage.array(),
            stage_cpu_s=self._stage_cpu.array(),
        )
