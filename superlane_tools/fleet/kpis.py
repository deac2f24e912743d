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
CPU_MS_SUFFIX = "_cpu_ms"
"""Per-frame thread CPU time of a stage (``frames.parquet``), milliseconds."""


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


def _in_range(index: NDArray[np.int64], start: int, stop: int) -> NDArray[np.bool_]:
    return (index >= start) & (index < stop)


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


def _seq_sum(index: NDArray[np.int64], values: FloatArray, start: int, stop: int) -> float:
    return float(values[_in_range(index, start, stop)].sum())


def sequence_kpis(tables: DriveTables) -> pd.DataFrame:
    """Return the drive's per-sequence KPI sums: one row per sequence and KPI.

    Columns: ``sequence``, ``start``, ``stop``, ``start_ns``, ``category``, ``kpi``, ``num``,
    ``den`` (see the module docstring; ``den`` 0: no value).
    """
    seqs = sequences(tables)
    per_kpi: dict[str, tuple[FloatArray, FloatArray]] = {}
    ranges = list(zip(seqs["start"].astype(int), seqs["stop"].astype(int), strict=True))
    avail = tables.availability_sequences
    for method in METHODS:
        sel = avail[avail["method"] == method].drop_duplicates("sequence").set_index("sequence")
        sel = sel.reindex(seqs["sequence"])
        ran = sel["n_frames"].notna().to_numpy(bool)
        if "method_available" in sel:
            ran = ran & sel["method_available"].fillna(False).to_numpy(bool)
        fn = np.where(ran, np.nan_to_num(sel["n_available"].to_numpy(np.float64)), 0.0)
        fd = np.where(ran, np.nan_to_num(sel["n_frames"].to_numpy(np.float64)), 0.0)
        decided = sel["available"].astype("boolean")
        sd = (ran & decided.notna().to_numpy(bool)).astype(np.float64)
        sn = np.where(sd > 0, decided.fillna(False).to_numpy(bool), False).astype(np.float64)
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
                np.array([_seq_sum(idx, sq, a, b) for a, b in ranges]),
                np.array([_seq_sum(idx, ok, a, b) for a, b in ranges]),
            )
    per_kpi |= _width_kpis(tables, ranges)
    per_kpi |= _fit_kpis(tables, ranges)
    rows = []
    for name, (num, den) in per_kpi.items():
        part = seqs.copy()
        part["kpi"], part["num"], part["den"] = name, num, den
        rows.append(part)
    return pd.concat(rows, ignore_index=True)  # KPI order: that of KPIS


def _width_kpis(
    tables: DriveTables, ranges: list[tuple[int, int]]
) -> dict[str, tuple[FloatArray, FloatArray]]:
    idx, super_w = _width(tables, "super")
    me_idx, me_w = _width(tables, "mobileye")
    me = pd.Series(me_w, index=me_idx).reindex(idx).to_numpy(np.float64)
    both = np.isfinite(super_w) & np.isfinite(me)
    diff = np.where(both, super_w - me, 0.0)
    step = np.diff(super_w, prepend=np.nan)
    consecutive = np.diff(idx, prepend=-2) == 1
    ok_step = np.isfinite(step) & consecutive
    step2 = np.where(ok_step, step * step, 0.0)
    bias_n, bias_d, jit_n, jit_d = [], [], [], []
    for a, b in ranges:
        inside = _in_range(idx, a, b)
        bias_n.append(float(diff[inside].sum()))
        bias_d.append(float(both[inside].sum()))
        inner = inside & _in_range(idx, a + 1, b)  # steps inside the sequence only
        jit_n.append(float(step2[inner].sum()))
        jit_d.append(float(ok_step[inner].sum()))
    return {
        "lane_width_bias": (np.array(bias_n), np.array(bias_d)),
        "lane_width_jitter": (np.array(jit_n), np.array(jit_d)),
    }


def _fit_kpis(
    tables: DriveTables, ranges: list[tuple[int, int]]
) -> dict[str, tuple[FloatArray, FloatArray]]:
    lanes, frames = tables.lanes, tables.frames
    idx = lanes["frame_index"].to_numpy(np.int64)
    pair = ((lanes["ego_left"] >= 0) & (lanes["ego_right"] >= 0)).to_numpy(np.float64)
    cost = lanes["cost"].to_numpy(np.float64)
    has_cost = np.isfinite(cost)
    cost = np.where(has_cost, cost, 0.0)
    f_idx = frames["frame_index"].to_numpy(np.int64)
    stages = [c for c in frames.columns if c.endswith(CPU_MS_SUFFIX)]
    stage_s = frames[stages].fillna(0.0).to_numpy(np.float64).sum(axis=1) / 1e3
    out: dict[str, list[float]] = {k: [] for k in ("pn", "pd", "cn", "cd", "fn", "fd")}
    for a, b in ranges:
        inside = _in_range(idx, a, b)
        out["pn"].append(float(pair[inside].sum()))
        out["pd"].append(float(inside.sum()))
        out["cn"].append(float(cost[inside & has_cost].sum()))
        out["cd"].append(float((inside & has_cost).sum()))
        f_in = _in_range(f_idx, a, b)
        out["fn"].append(float(f_in.sum()))
        out["fd"].append(float(stage_s[f_in].sum()))
    arr = {k: np.array(v) for k, v in out.items()}
    return {
        "ego_pair_share": (arr["pn"], arr["pd"]),
        "fit_cost": (arr["cn"], arr["cd"]),
        "frames_per_s": (arr["fn"], arr["fd"]),
    }
