"""Per-sequence KPIs of one reprocessed drive, as sums that pool into fleet values.

Every KPI of a sequence is a pair ``(num, den)``: the fleet (or drive, or category) value is
``transform(sum(num) / sum(den))`` over its sequences, so a pooled value weighs each frame once
(availability is available frames over frames, RMSE the root of the pooled mean square). A
sequence whose ``den`` is 0 has no value for that KPI (no truth, method not run): the KPI is
*unavailable* there, never 0.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.reporting.drive_tables import METHODS
from superlane_tools.reporting.names import AVAILABILITY_NAMES, curvature_name

FloatArray = NDArray[np.float64]
CURVATURE_KPI_SOURCES = ("super_path", "super")
"""SUPER curvature sources compared: the tracked path estimate and the raw ``2*a2``."""


@dataclass(frozen=True)
class Kpi:
    """One KPI: how its sequence sums pool and which direction is better.

    Attributes:
        name: Identifier (``availability_frames.super``), used by ``--fail-on-regression``.
        label: Display name.
        unit: Unit of the value (``ratio`` is 0-1, shown as %).
        higher_is_better: Direction of "better".
        transform: ``sqrt`` (a pooled mean square -> RMS), ``abs`` or ``none``.
        min_relative: Smallest relative change (of the base value) that counts as a change,
            whatever the interval says (0: any significant change counts). Used for frames/s,
            a timing measurement that varies between runs of identical code.
    """

    name: str
    label: str
    unit: str
    higher_is_better: bool
    transform: str = "none"
    min_relative: float = 0.0

    @property
    def family(self) -> str:
        """Return the part of the name before the dot (``availability_frames``)."""
        return self.name.partition(".")[0]

    def pooled(self, num: FloatArray, den: FloatArray) -> FloatArray:
        """Return ``transform(num / den)`` elementwise (NaN where ``den`` is 0)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
        if self.transform == "sqrt":
            return np.sqrt(mean)
        if self.transform == "abs":
            return np.abs(mean)
        return np.asarray(mean, dtype=np.float64)


def _kpis() -> tuple[Kpi, ...]:
    out: list[Kpi] = []
    for method in METHODS:
        label = AVAILABILITY_NAMES.get(method, method)
        out.append(
            Kpi(f"availability_frames.{method}", f"{label} availability (frames)", "ratio", True)
        )
        out.append(
            Kpi(
                f"availability_sequences.{method}",
                f"{label} availability (sequences)",
                "ratio",
                True,
            )
        )
    for source in CURVATURE_KPI_SOURCES:
        name = curvature_name(source)
        out.append(
            Kpi(
                f"curvature_rmse_truth.{source}",
                f"{name}: curvature RMSE vs RTK truth",
                "1/m",
                False,
                "sqrt",
            )
        )
        out.append(
            Kpi(
                f"curvature_rmse_dynamics.{source}",
                f"{name}: curvature RMSE vs yaw rate / speed",
                "1/m",
                False,
                "sqrt",
            )
        )
    out += [
        Kpi("lane_width_bias", "SUPER lane width bias vs Mobileye (|mean|)", "m", False, "abs"),
        Kpi(
            "lane_width_jitter",
            "SUPER lane width jitter (RMS frame-to-frame change)",
            "m",
            False,
            "sqrt",
        ),
        Kpi("ego_pair_share", "Frames with an ego line pair", "ratio", True),
        Kpi("fit_cost", "SUPER fit residual (mean cost J)", "J", False),
        Kpi(
            "frames_per_s",
            "Processing frames per CPU second (stage CPU time)",
            "1/s",
            True,
            min_relative=0.2,
        ),
    ]
    return tuple(out)


KPIS: tuple[Kpi, ...] = _kpis()
"""Every KPI ``slt compare`` reports, in report order."""
KPI_BY_NAME: Mapping[str, Kpi] = {k.name: k for k in KPIS}


@dataclass(frozen=True)
class DriveTables:
    """The tables of one reprocessed drive that the KPIs read (as written by ``slt reprocess``).

    Attributes:
        availability_frames: Long per-frame availability (``method``, ``width_m``, ...).
        availability_sequences: Per-sequence availability (``start``/``stop`` frame indices).
        curvature: Per-frame curvature estimates and truth (may lack the truth columns).
        lanes: Per-frame SUPER fit (``ego_left``, ``ego_right``, ``cost``).
        frames: Per-frame stage times (``<stage>_ms``).
    """

    availability_frames: pd.DataFrame
    availability_sequences: pd.DataFrame
    curvature: pd.DataFrame
    lanes: pd.DataFrame
    frames: pd.DataFrame


SEQUENCE_COLUMNS = ("sequence", "start", "stop", "start_ns", "category")


def sequences(tables: DriveTables) -> pd.DataFrame:
    """Return the drive's KPI sequences: index, frames ``[start, stop)``, start time, category."""
    seqs = tables.availability_sequences
    if seqs.empty:
        return pd.DataFrame(columns=list(SEQUENCE_COLUMNS))
    first = seqs[seqs["method"] == seqs["method"].iloc[0]]
    out = first[["sequence", "start", "stop", "start_ns"]].copy()
    cat = first["category"].astype(str) if "category" in first else pd.Series("", first.index)
    out["category"] = cat.to_numpy()
    result: pd.DataFrame = out.reset_index(drop=True)
    return result


def _width(tables: DriveTables, method: str) -> tuple[NDArray[np.int64], FloatArray]:
    fr = tables.availability_frames
    sel = fr[fr["method"] == method]
    return sel["frame_index"].to_numpy(np.int64), sel["width_m"].to_numpy(np.float64)


def _curvature_sums(
    curv: pd.DataFrame, source: str, reference: str, valid: str | None
) -> tuple[NDArray[np.int64], FloatArray, FloatArray]:
    """Return frame index, squared error and 1 for frames with both values (else 0, 0)."""
    column, ref_col = f"{source}_curvature", f"{reference}_curvature"
    index = curv["frame_index"].to_numpy(np.int64) if "frame_index" in curv else np.zeros(0, int)
    if column not in curv or ref_col not in curv:
        return index, np.zeros(len(index)), np.zeros(len(index))
    est = curv[column].to_numpy(np.float64)
    ref = curv[ref_col].to_numpy(np.float64)
    ok = np.isfinite(est) & np.isfinite(ref)
    if valid is not None and valid in curv:
        ok &= curv[valid].to_numpy(bool)
    err = np.where(ok, est - ref, 0.0)
    return index, err * err, ok.astype(np.float64)


def range_sums(
    index: NDArray[np.int64],
    values: FloatArray,
    starts: NDArray[np.int64],
    stops: NDArray[np.int64],
) -> FloatArray:
    """Return the sums of ``values`` whose frame ``index`` is in each ``[start, stop)``."""
    order = np.argsort(index, kind="stable")
    idx = index[order]
    cum = np.concatenate([[0.0], np.cumsum(np.asarray(values, dtype=np.float64)[order])])
    return np.asarray(cum[np.searchsorted(idx, stops)] - cum[np.searchsorted(idx, starts)])


def sequence_kpis(tables: DriveTables) -> pd.DataFrame:
    """Return the drive's per-sequence KPI sums: one row per sequence and KPI.

    Columns: ``sequence``, ``start``, ``stop``, ``start_ns``, ``category``, ``kpi``, ``num``,
    ``den`` (see the module docstring; ``den`` 0: no value).
    """
    seqs = sequences(tables)
    per_kpi: dict[str, tuple[FloatArray, FloatArray]] = {}
    starts = seqs["start"].to_numpy(np.int64)
    stops = seqs["stop"].to_numpy(np.int64)
    avail = tables.availability_sequences
    n = len(seqs)
    seq_ids = seqs["sequence"].to_numpy(np.int64)
    a_method = avail["method"].to_numpy(object)
    a_seq = avail["sequence"].to_numpy(np.int64)
    a_ran = (
        avail["method_available"].fillna(False).to_numpy(bool)
        if "method_available" in avail
        else np.ones(len(avail), bool)
    )
    a_n = np.nan_to_num(avail["n_available"].to_numpy(np.float64))
    a_big_n = np.nan_to_num(avail["n_frames"].to_numpy(np.float64))
    decided = avail["available"].astype("boolean")
    a_known = decided.notna().to_numpy(bool)
    a_yes = decided.fillna(False).to_numpy(bool)
    order = np.argsort(seq_ids, kind="stable")
    for method in METHODS:
        rows = np.flatnonzero(a_method == method)
        pos = np.searchsorted(seq_ids[order], a_seq[rows])
        hit = pos < n
        hit[hit] &= seq_ids[order][pos[hit]] == a_seq[rows][hit]
        rows, at = rows[hit], order[pos[hit]]
        fn, fd, sn, sd = (np.zeros(n) for _ in range(4))
        ran = a_ran[rows]
        fn[at] = np.where(ran, a_n[rows], 0.0)
        fd[at] = np.where(ran, a_big_n[rows], 0.0)
        sd[at] = (ran & a_known[rows]).astype(np.float64)
        sn[at] = (ran & a_known[rows] & a_yes[rows]).astype(np.float64)
        per_kpi[f"availability_frames.{method}"] = (fn, fd)
        per_kpi[f"availability_sequences.{method}"] = (sn, sd)
    curv = tables.curvature
    for source in CURVATURE_KPI_SOURCES:
        for family, ref, valid in (
            ("curvature_rmse_truth", "rtk", "rtk_valid"),
            ("curvature_rmse_dynamics", "dynamics", None),
        ):
            idx, sq, ok = _curvature_sums(curv, source, ref, valid)
            per_kpi[f"{family}.{source}"] = (
                range_sums(idx, sq, starts, stops),
                range_sums(idx, ok, starts, stops),
            )
    per_kpi |= _width_kpis(tables, starts, stops)
    per_kpi |= _fit_kpis(tables, starts, stops)
    out = {c: np.tile(seqs[c].to_numpy(), len(per_kpi)) for c in SEQUENCE_COLUMNS}
    out["kpi"] = np.repeat(np.array(list(per_kpi), dtype=object), n)
    out["num"] = np.concatenate([v[0] for v in per_kpi.values()]) if n else np.zeros(0)
    out["den"] = np.concatenate([v[1] for v in per_kpi.values()]) if n else np.zeros(0)
    return pd.DataFrame(out)  # KPI order: that of KPIS


def _width_kpis(
    tables: DriveTables, starts: NDArray[np.int64], stops: NDArray[np.int64]
) -> dict[str, tuple[FloatArray, FloatArray]]:
    idx, super_w = _width(tables, "super")
    me_idx, me_w = _width(tables, "mobileye")
    me_series = pd.Series(me_w, index=me_idx)
    me = me_series[~me_series.index.duplicated()].reindex(idx).to_numpy(np.float64)
    both = np.isfinite(super_w) & np.isfinite(me)
    diff = np.where(both, super_w - me, 0.0)
    step = np.diff(super_w, prepend=np.nan)
    ok_step = np.isfinite(step) & (np.diff(idx, prepend=-2) == 1)
    step2 = np.where(ok_step, step * step, 0.0)
    inner = starts + 1  # a step into a sequence's first frame belongs to the one before
    return {
        "lane_width_bias": (
            range_sums(idx, diff, starts, stops),
            range_sums(idx, both.astype(np.float64), starts, stops),
        ),
        "lane_width_jitter": (
            range_sums(idx, step2, inner, stops),
            range_sums(idx, ok_step.astype(np.float64), inner, stops),
        ),
    }


def _fit_kpis(
    tables: DriveTables, starts: NDArray[np.int64], stops: NDArray[np.int64]
) -> dict[str, tuple[FloatArray, FloatArray]]:
    lanes, frames = tables.lanes, tables.frames
    idx = lanes["frame_index"].to_numpy(np.int64)
    pair: FloatArray = np.asarray(
        ((lanes["ego_left"] >= 0) & (lanes["ego_right"] >= 0)).to_numpy(), dtype=np.float64
    )
    cost = lanes["cost"].to_numpy(np.float64)
    has_cost = np.isfinite(cost).astype(np.float64)
    f_idx = frames["frame_index"].to_numpy(np.int64)
    stages = [c for c in frames.columns if c.endswith("_cpu_ms")]  # stage thread CPU time
    stage_s = frames[stages].fillna(0.0).to_numpy(np.float64).sum(axis=1) / 1e3
    return {
        "ego_pair_share": (
            range_sums(idx, pair, starts, stops),
            range_sums(idx, np.ones(len(idx)), starts, stops),
        ),
        "fit_cost": (
            range_sums(idx, np.where(has_cost > 0, cost, 0.0), starts, stops),
            range_sums(idx, has_cost, starts, stops),
        ),
        "frames_per_s": (
            range_sums(f_idx, np.ones(len(f_idx)), starts, stops),
            range_sums(f_idx, stage_s, starts, stops),
        ),
    }
