"""Where two runs of one drive disagree most: a per-frame disagreement score and its spans.

Per frame, the score adds (each term 0-1): for every availability method that ran in both
runs, 1 where one run has the frame available and the other not; SUPER's lane width change
over ``width_scale_m``; SUPER's raw curvature change over ``curvature_scale_per_m``. The score
is smoothed over ``smooth_s``; spans are the runs of frames whose smoothed score reaches
``threshold`` (gaps shorter than ``smooth_s`` joined), ranked by their summed score.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.fleet.kpis import DriveTables
from superlane_tools.reporting.drive_tables import METHODS
from superlane_tools.reporting.layout import COMPARE_SPANS_TABLE

FloatArray = NDArray[np.float64]
SPAN_COLUMNS = COMPARE_SPANS_TABLE.pick(
    "drive",
    "start_ns",
    "stop_ns",
    "start_s",
    "duration_s",
    "first_frame",
    "last_frame",
    "score",
    "peak_score",
    "main_difference",
)
"""A drive's span columns (``slt compare`` adds the recording and both runs' annotations)."""


@dataclass(frozen=True)
class SpanParams:
    """How disagreement spans are found (see the module docstring)."""

    width_scale_m: float = 0.5
    curvature_scale_per_m: float = 1e-3
    smooth_s: float = 0.5
    threshold: float = 0.5
    max_spans: int = 10


class FrameDisagreement(NamedTuple):
    """Per-frame disagreement of two runs of one drive (frames both runs processed)."""

    frame_index: NDArray[np.int64]
    log_time_ns: NDArray[np.int64]
    terms: dict[str, FloatArray]

    @property
    def score(self) -> FloatArray:
        """Return the summed per-frame score."""
        if not self.terms:
            return np.zeros(len(self.frame_index))
        total: FloatArray = np.sum(np.stack(list(self.terms.values())), axis=0)
        return total


def per_method(frames: pd.DataFrame, column: str) -> dict[str, pd.Series]:
    """Return method -> ``column`` of a long per-frame table by frame index (first per frame)."""
    out = {}
    for method, group in frames.groupby("method", sort=False):
        series = pd.Series(group[column].to_numpy(), index=group["frame_index"].to_numpy())
        out[str(method)] = series[~series.index.duplicated()]
    return out


def frame_disagreement(
    base: DriveTables, candidate: DriveTables, params: SpanParams
) -> FrameDisagreement:
    """Return the per-frame disagreement terms of two runs of the same drive."""
    fb, fc = base.availability_frames, candidate.availability_frames
    times = fb.drop_duplicates("frame_index").set_index("frame_index")["log_time_ns"]
    idx = np.intersect1d(times.index.to_numpy(), fc["frame_index"].unique())
    ab = per_method(fb.assign(available=fb["available"].astype(float)), "available")
    ac = per_method(fc.assign(available=fc["available"].astype(float)), "available")
    terms: dict[str, FloatArray] = {}
    for method in METHODS:
        if method in ab and method in ac:
            x = ab[method].reindex(idx).to_numpy(np.float64)
            y = ac[method].reindex(idx).to_numpy(np.float64)
            flip = np.nan_to_num(np.abs(x - y))
            if flip.any():
                terms[f"{method} availability"] = flip
    wb = per_method(fb, "width_m")["super"].reindex(idx).to_numpy(np.float64)
    wc = per_method(fc, "width_m")["super"].reindex(idx).to_numpy(np.float64)
    terms["SUPER lane width"] = np.nan_to_num(
        np.minimum(np.abs(wc - wb) / params.width_scale_m, 1.0)
    )
    kb = _curvature(base.curvature, idx)
    kc = _curvature(candidate.curvature, idx)
    terms["SUPER curvature"] = np.nan_to_num(
        np.minimum(np.abs(kc - kb) / params.curvature_scale_per_m, 1.0)
    )
    return FrameDisagreement(idx.astype(np.int64), times.reindex(idx).to_numpy(np.int64), terms)


def _curvature(curv: pd.DataFrame, idx: NDArray[np.int64]) -> FloatArray:
    if "super_curvature" not in curv or curv.empty:
        return np.full(len(idx), np.nan)
    series = curv.set_index("frame_index")["super_curvature"]
    return series[~series.index.duplicated()].reindex(idx).to_numpy(np.float64)


def _runs(mask: NDArray[np.bool_], join: int) -> list[tuple[int, int]]:
    """Return ``[start, stop)`` runs of True, joining gaps shorter than ``join`` frames."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    runs = [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    joined: list[tuple[int, int]] = []
    for a, b in runs:
        if joined and a - joined[-1][1] < join:
            joined[-1] = (joined[-1][0], b)
        else:
            joined.append((a, b))
    return joined


def disagreement_spans(drive: str, dis: FrameDisagreement, params: SpanParams) -> pd.DataFrame:
    """Return the drive's disagreement spans, worst first (columns :data:`SPAN_COLUMNS`).

    ``stop_ns`` is exclusive: one frame period after the span's last frame.
    """
    n = len(dis.frame_index)
    if n == 0:
        return pd.DataFrame(columns=list(SPAN_COLUMNS))
    t = dis.log_time_ns
    period = float(np.median(np.diff(t))) if n > 1 else 1e8
    win = max(1, round(params.smooth_s * 1e9 / period))
    score = dis.score
    smooth = np.convolve(score, np.ones(win) / win, mode="same")
    rows = []
    for a, b in _runs(smooth >= params.threshold, win):
        parts = {name: float(term[a:b].sum()) for name, term in dis.terms.items()}
        rows.append(
            {
                "drive": drive,
                "start_ns": int(t[a]),
                "stop_ns": int(t[b - 1] + period),
                "start_s": (t[a] - t[0]) / 1e9,
                "duration_s": (t[b - 1] + period - t[a]) / 1e9,
                "first_frame": int(dis.frame_index[a]),
                "last_frame": int(dis.frame_index[b - 1]),
                "score": float(score[a:b].sum()),
                "peak_score": float(score[a:b].max()),
                "main_difference": max(parts, key=lambda k: parts[k]),
            }
        )
    spans = pd.DataFrame(rows, columns=list(SPAN_COLUMNS))
    return spans.sort_values("score", ascending=False).head(params.max_spans).reset_index(drop=True)
