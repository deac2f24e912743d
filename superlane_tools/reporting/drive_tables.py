"""The derived KPI tables of a reprocessed drive: availability and the curvature summary.

Their file names and the streamed tables' schemas are in :mod:`.layout`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.corridor import (
    AvailabilityParams,
    FrameAvailability,
    Segment,
    frame_availability,
    sequence_availability,
)
from superlane_tools.evaluation import curvature_errors
from superlane_tools.reporting.names import METHOD_NOT_RUN

FloatArray = NDArray[np.float64]
METHODS = ("super", "corridor_net", "hough", "mobileye")
"""Availability methods: SUPER lane fit, ego-corridor network, Hough baseline, Mobileye."""


def availability_tables(
    t_ns: NDArray[np.int64],
    geometry: dict[str, tuple[FloatArray, FloatArray]],
    unavailable: dict[str, str],
    speed_mps: FloatArray,
    params: AvailabilityParams,
    segments: Sequence[Segment] | None,
) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, FrameAvailability]]:
    """Compute per-frame and per-sequence availability of every method.

    Args:
        t_ns: Frame times, ns.
        geometry: Method -> (corridor width m, corridor length m) per frame.
        unavailable: Method -> why the whole method is unavailable (e.g. no corridor model).
        speed_mps: CAN speed at each frame (NaN unknown).
        params: Thresholds, window and frame rate.
        segments: Labelled segments, or None for consecutive windows.

    Returns:
        The long per-frame table, the per-sequence table, and the per-method frame results.
        Every method's width is measured at ``params.width_at_m`` ahead (at the corridor's far
        end when it is shorter: the per-frame ``width_at_m``), and widths and lengths are
        measured from one origin, the camera's vehicle frame (the camera foot by default).
    """
    frame_parts = []
    seq_rows = []
    results: dict[str, FrameAvailability] = {}
    n = len(t_ns)
    for method in METHODS:
        width, length = geometry[method]
        fa = frame_availability(width, length, speed_mps, params)
        reason = fa.reason.astype(object)
        if method in unavailable:
            reason[:] = f"{METHOD_NOT_RUN}: {unavailable[method]}"
        results[method] = fa
        frame_parts.append(
            pd.DataFrame(
                {
                    "frame_index": np.arange(n, dtype=np.int32),
                    "log_time_ns": t_ns,
                    "method": method,
                    "width_m": width,
                    "width_at_m": np.where(
                        np.isfinite(width), np.fmin(params.width_at_m, length), np.nan
                    ),
                    "length_m": length,
                    "speed_mps": speed_mps,
                    "required_length_m": np.abs(speed_mps) * params.time_gap_s,
                    "available": fa.available,
                    "known": fa.known,
                    "reason": reason.astype(str),
                }
            )
        )
        if n == 0:
            continue
        for k, seq in enumerate(sequence_availability(fa, params, segments, t_ns)):
            row = seq._asdict()
            row.update(
                method=method,
                sequence=k,
                start_ns=int(t_ns[seq.start]),
                method_available=method not in unavailable,
                width_at_m=params.width_at_m,
                median_width_m=_nanmedian(width[seq.start : seq.stop]),
                median_length_m=_nanmedian(length[seq.start : seq.stop]),
            )
            seq_rows.append(row)
    frames = pd.concat(frame_parts, ignore_index=True)
    seqs = pd.DataFrame(seq_rows)
    if not seqs.empty:
        seqs["available"] = seqs["available"].astype("boolean")
    return frames, seqs, results


def _nanmedian(values: FloatArray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if finite.size else float("nan")


CURVATURE_SOURCES = (
    "super",
    "super_road",
    "super_path",
    "super_road_sg",
    "super_path_sg",
    "mobileye",
    "mobileye_path",
    "dynamics",
)
"""Curvature estimates compared with RTK (``<source>_curvature`` columns of curvature.parquet).

``super_road`` / ``super_path`` come from the lane tracker when it is enabled; ``*_sg`` are the
same without it (look-ahead alignment and the truth's filter only). ``mobileye`` is Mobileye's
raw ``2*C2``; ``mobileye_path`` gives it SUPER's treatment (the truth's filter and the
manoeuvre term from its own ``C0``). ``dynamics`` is yaw rate / speed smoothed like the truth.
"""


def curvature_summary(curv: pd.DataFrame, segments: Sequence[Segment]) -> pd.DataFrame:
    """Errors of SUPER and Mobileye curvature against RTK, overall and per sequence."""
    rows = []
    spans = [("overall", 0, len(curv), "")] + [
        (f"seq{k}", s.start, s.stop, s.category) for k, s in enumerate(segments)
    ]
    truth = curv["rtk_curvature"].to_numpy(dtype=np.float64)
    for scope, start, stop, category in spans:
        for source in CURVATURE_SOURCES:
            est = curv[f"{source}_curvature"].to_numpy(dtype=np.float64)
            err = curvature_errors(est[start:stop], truth[start:stop])
            rows.append(
                {
                    "scope": scope,
                    "category": category,
                    "start": start,
                    "stop": stop,
                    "source": source,
                    **err._asdict(),
                }
            )
    return pd.DataFrame(rows)
