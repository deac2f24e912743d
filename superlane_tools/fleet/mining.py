"""Frames worth labelling: per-frame criteria from a run's tables, then a spread-out selection.

Criteria (each a per-frame score 0-1; a frame *fires* a criterion at score >= 0.5):

* ``disagree``: SUPER against the corridor network, Mobileye and Hough: the lane width
  difference over 1 m (score 1 from 1 m), or one available and the other not. Hough, a weak
  baseline, counts for availability only where SUPER is the one that lost the lane: on a clean
  simulated drive Hough is unavailable on 22 % of the frames where SUPER has its lanes, and
  those frames are not SUPER's failures (they made a normal drive's picks near-uniform).
* ``availability_drop``: SUPER unavailable while the frame's availability is known.
* ``fit_quality``: the SUPER fit's self-check quality below 0.5 (score ``1 - quality``).
* ``lane_change``: the vehicle's lateral position in its lane jumps by more than 1 m between
  frames (the ego lane changed).
* ``curvature_extreme``: |curvature| (RTK truth, else SUPER's tracked path) above
  ``curvature_per_m`` (score 0.5 there, 1 at twice it).
* ``span``: inside a ``slt compare`` disagreement span of this drive.
* ``low_light``: the camera frame is night-dark or low in contrast
  (:func:`superlane_tools.fleet.lighting.low_light_score`: mean luminance under 0.2 or RMS
  contrast under 0.08). The one criterion that reads the recording (every frame decoded,
  reduced, grayscale), so it is not a default: only computed when chosen; a frame without
  statistics (recording not found, frame not decodable) gets no score (NaN), never 0.

Frames are picked by summed score, at most ``max_frames``, at most ``max_per_drive`` of one
drive (so one bad drive cannot fill the set), never two of one drive closer than ``min_gap_s``
(near-duplicate neighbours), so picks spread over time and over the fleet.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.kpis import DriveTables
from superlane_tools.fleet.spans import per_method

FloatArray = NDArray[np.float64]
TABLE_CRITERIA = (
    "disagree",
    "availability_drop",
    "fit_quality",
    "lane_change",
    "curvature_extreme",
    "span",
)
"""Criteria computed from the run's tables: the default."""
IMAGE_CRITERIA = ("low_light",)
"""Criteria that decode the recording's frames: chosen explicitly."""
CRITERIA = TABLE_CRITERIA + IMAGE_CRITERIA
FIRES = 0.5
WEAK_REFERENCES = frozenset({"hough"})
"""Methods whose availability counts against SUPER only where SUPER lost the lane."""
MAX_PER_DRIVE = 10
"""Default cap on the frames picked from one drive (a fifth of the default 50-frame set)."""


@dataclass(frozen=True)
class MineParams:
    """Which criteria, how they combine, and how many frames how far apart."""

    criteria: tuple[str, ...] = TABLE_CRITERIA
    require_all: bool = False
    max_frames: int = 50
    min_gap_s: float = 1.0
    curvature_per_m: float = 1.0 / 250.0
    max_per_drive: int | None = MAX_PER_DRIVE

    def __post_init__(self) -> None:
        """Reject unknown criteria and impossible counts."""
        unknown = [c for c in self.criteria if c not in CRITERIA]
        if unknown or not self.criteria:
            raise FleetError(f"unknown criteria {unknown}: choose from {', '.join(CRITERIA)}")
        if self.max_frames < 1 or self.min_gap_s < 0:
            raise FleetError("max_frames must be >= 1 and min_gap_s >= 0")
        if self.max_per_drive is not None and self.max_per_drive < 1:
            raise FleetError("max_per_drive must be >= 1 (or None: no cap)")


def _by_frame(series: pd.Series, index: NDArray[np.int64]) -> FloatArray:
    return series[~series.index.duplicated()].reindex(index).to_numpy(np.float64)


def frame_scores(
    tables: DriveTables,
    spans: Sequence[tuple[int, int]],
    params: MineParams,
    lighting: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Return one row per frame: ``frame_index``, ``log_time_ns`` and a score per criterion.

    ``spans``: ``[start_ns, stop_ns)`` disagreement spans of this drive (may be empty).
    ``lighting``: ``log_time_ns`` and ``low_light`` per camera frame
    (:func:`~superlane_tools.fleet.lighting.lighting_table`); with ``low_light`` chosen, the
    frames it lacks (or all, when None) score NaN. The column is there only when chosen.
    """
    fr = tables.availability_frames
    times = fr.drop_duplicates("frame_index").set_index("frame_index")["log_time_ns"].sort_index()
    idx = times.index.to_numpy(np.int64)
    out = pd.DataFrame({"frame_index": idx, "log_time_ns": times.to_numpy(np.int64)})
    fr = fr.assign(
        available=fr["available"].astype(float),
        known=fr["known"].astype(float) if "known" in fr else 1.0,
    )
    width = {m: s.reindex(idx).to_numpy(np.float64) for m, s in per_method(fr, "width_m").items()}
    avail = {m: s.reindex(idx).to_numpy(np.float64) for m, s in per_method(fr, "available").items()}
    known = per_method(fr, "known")["super"].reindex(idx).to_numpy(np.float64)
    sup_w, sup_a = width["super"], avail["super"]
    dis = np.zeros(len(idx))
    for other in ("corridor_net", "mobileye", "hough"):
        if other not in width:
            continue
        dw = np.nan_to_num(np.abs(sup_w - width[other]))
        lost = avail[other] - sup_a if other in WEAK_REFERENCES else np.abs(sup_a - avail[other])
        flip = np.clip(np.nan_to_num(lost), 0.0, 1.0)
        dis = np.maximum(dis, np.maximum(np.minimum(dw, 1.0), flip))
    out["disagree"] = dis
    out["availability_drop"] = ((sup_a == 0) & (known == 1)).astype(float)
    lanes = tables.lanes.set_index("frame_index")
    quality = _by_frame(lanes["quality"], idx) if "quality" in lanes else np.full(len(idx), np.nan)
    out["fit_quality"] = np.where(np.isfinite(quality), 1.0 - quality, 0.0)
    curv = tables.curvature.set_index("frame_index") if "frame_index" in tables.curvature else None
    lateral = _column(curv, "super_lateral_m", idx)
    out["lane_change"] = (np.abs(np.diff(lateral, prepend=np.nan)) > 1.0).astype(float)
    k = _column(curv, "rtk_curvature", idx)
    k = np.where(np.isfinite(k), k, _column(curv, "super_path_curvature", idx))
    out["curvature_extreme"] = np.nan_to_num(
        np.minimum(np.abs(k) / (2 * params.curvature_per_m), 1.0)
    )
    t = out["log_time_ns"].to_numpy(np.int64)
    inside = np.zeros(len(idx), bool)
    for start, stop in spans:
        inside |= (t >= start) & (t < stop)
    out["span"] = inside.astype(float)
    if "low_light" in params.criteria:
        light = pd.Series(dtype=float) if lighting is None else _by_time(lighting)
        out["low_light"] = light.reindex(t).to_numpy(np.float64)
    return out


def _by_time(lighting: pd.DataFrame) -> pd.Series:
    series = lighting.set_index("log_time_ns")["low_light"].astype(float)
    return series[~series.index.duplicated()]


def _column(frame: pd.DataFrame | None, name: str, idx: NDArray[np.int64]) -> FloatArray:
    if frame is None or name not in frame:
        return np.full(len(idx), np.nan)
    return _by_frame(frame[name], idx)


def candidates(scores: pd.DataFrame, params: MineParams) -> pd.DataFrame:
    """Return the frames that fire the chosen criteria, with ``score`` and ``reasons``."""
    fired = scores[list(params.criteria)] >= FIRES
    keep = fired.all(axis=1) if params.require_all else fired.any(axis=1)
    chosen = scores[keep].copy()
    chosen["score"] = (scores.loc[keep, list(params.criteria)] * fired[keep]).sum(axis=1)
    chosen["reasons"] = [
        ",".join(c for c in params.criteria if row[c]) for _, row in fired[keep].iterrows()
    ]
    return chosen


def select_frames(pool: pd.DataFrame, params: MineParams) -> pd.DataFrame:
    """Pick the best-scoring frames, spread out: at most ``max_frames``, ``min_gap_s`` apart.

    ``pool`` has a ``drive``, ``log_time_ns`` and ``score`` column (frames of many drives).
    At most ``max_per_drive`` frames come from one drive.
    """
    gap = int(params.min_gap_s * 1e9)
    cap = params.max_per_drive or params.max_frames
    taken: dict[str, list[int]] = {}
    rows = []
    order = pool.sort_values(["score", "log_time_ns"], ascending=[False, True], kind="stable")
    for pos, drive, t in zip(order.index, order["drive"], order["log_time_ns"], strict=True):
        near = taken.setdefault(str(drive), [])
        if len(near) >= cap or any(abs(int(t) - u) < gap for u in near):
            continue
        near.append(int(t))
        rows.append(pos)
        if len(rows) >= params.max_frames:
            break
    return pool.loc[rows].sort_values(["drive", "log_time_ns"]).reset_index(drop=True)
