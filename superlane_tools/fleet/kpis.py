"""Per-sequence KPIs of one reprocessed drive, as sums that pool into fleet values.

Every KPI of a sequence is a pair ``(num, den)``: the fleet (or drive, or category) value is
``transform(sum(num) / sum(den))`` over its sequences, so a pooled value weighs each frame once
(availability is available frames over frames, RMSE the root of the pooled mean square). A
sequence whose ``den`` is 0 has no value for that KPI (no truth, method not run): the KPI is
*unavailable* there, never 0.

*Conditional* KPIs (fit cost, width jitter, the curvature RMSEs) exist only on frames where a run
produced a value, so a run that gives up on hard frames would look better. Given the other
run's tables, they are computed on the frames **both** runs produced, and each has a coverage
KPI (``coverage.*``: frames with a value / frames) that shows what was given up.
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
        margin: The change that matters in practice, in the KPI's unit (a change inside
            +-margin is "equivalent"; the release gate's default non-inferiority margin).
        relative_margin: A margin as a share of the base value instead (frames/s: a timing
            that varies between runs of identical code).
        per_drive: ``abs``: a drive's value is ``|sum num| / sum den`` (a signed bias that must
            not cancel between drives), else the plain sums.
        conditional: Defined only on frames where the run produced a value (compared on frames
            both runs produced, next to a coverage KPI).
    """

    name: str
    label: str
    unit: str
    higher_is_better: bool
    transform: str = "none"
    margin: float = 0.0
    relative_margin: float = 0.0
    per_drive: str = "none"
    conditional: bool = False

    def margin_for(self, base: float) -> float:
        """Return the margin in the KPI's unit (a relative margin scales the base value)."""
        if self.relative_margin > 0:
            return self.relative_margin * abs(base) if np.isfinite(base) else float("nan")
        return self.margin

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


FIT_COST_CLIP_J = 10.0
"""Each frame's fit cost J is clipped to +-this before averaging (typical frames: 1-5 J; a real
run had a few frames near -700 J that turned the mean negative)."""
CURVATURE_MARGIN_PER_M = 1e-4
"""Margin of the curvature RMSEs (1/m): the curvature of a 10 km radius."""


def _kpis() -> tuple[Kpi, ...]:
    out: list[Kpi] = []
    for method in METHODS:
        label = AVAILABILITY_NAMES.get(method, method)
        out.append(
            Kpi(
                f"availability_frames.{method}",
                f"{label} availability (frames)",
                "ratio",
                True,
                margin=0.02,
            )
        )
        out.append(
            Kpi(
                f"availability_sequences.{method}",
                f"{label} availability (sequences)",
                "ratio",
                True,
                margin=0.05,
            )
        )
    for source in CURVATURE_KPI_SOURCES:
        name = curvature_name(source)
        for family, what in (("truth", "RTK truth"), ("dynamics", "yaw rate / speed")):
            out.append(
                Kpi(
                    f"curvature_rmse_{family}.{source}",
                    f"{name}: curvature RMSE vs {what}",
                    "1/m",
                    False,
                    "sqrt",
                    margin=CURVATURE_MARGIN_PER_M,
                    conditional=True,
                )
            )
    out += [
        Kpi(
            "lane_width_bias",
            "SUPER lane width bias vs Mobileye (mean over drives of abs(drive mean))",
            "m",
            False,
            margin=0.05,
            per_drive="abs",
        ),
        Kpi(
            "lane_width_jitter",
            "SUPER lane width jitter (RMS frame-to-frame change)",
            "m",
            False,
            "sqrt",
            margin=0.02,
            conditional=True,
        ),
        Kpi("ego_pair_share", "Frames with an ego line pair", "ratio", True, margin=0.02),
        Kpi(
            "fit_cost",
            f"SUPER fit residual (mean cost J, each frame clipped to +-{FIT_COST_CLIP_J:g})",
            "J",
            False,
            margin=0.25,
            conditional=True,
        ),
        Kpi(
            "frames_per_s",
            "Processing frames per CPU second (stage CPU time)",
            "1/s",
            True,
            relative_margin=0.2,
        ),
    ]
    for name, what in COVERAGE_KPIS.items():
        out.append(Kpi(name, f"Coverage: frames with {what}", "ratio", True, margin=0.02))
    return tuple(out)


COVERAGE_KPIS: Mapping[str, str] = {
    "coverage.fit": "a SUPER fit cost",
    "coverage.width": "a SUPER lane width",
    **{
        f"coverage.curvature_{s}": f"a {curvature_name(s)} curvature" for s in CURVATURE_KPI_SOURCES
    },
}
"""The coverage KPIs beside the conditional ones (frames with a value / frames)."""
CONDITIONED_ON: Mapping[str, str] = {
    "fit_cost": "coverage.fit",
    "lane_width_jitter": "coverage.width",
    **{
        f"curvature_rmse_{f}.{s}": f"coverage.curvature_{s}"
        for f in ("truth", "dynamics")
        for s in CURVATURE_KPI_SOURCES
    },
}
"""Each conditional KPI's coverage KPI."""


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


Produced = Mapping[str, tuple[NDArray[np.int64], NDArray[np.bool_]]]
"""Per conditional value (``fit``, ``width``, ``step``, ``curvature_<source>``): frame index and
whether the run produced it there."""


def produced(tables: DriveTables) -> dict[str, tuple[NDArray[np.int64], NDArray[np.bool_]]]:
    """Return where a run produced each conditional value (see :data:`Produced`)."""
    lanes, curv = tables.lanes, tables.curvature
    idx, width = _width(tables, "super")
    step_ok = np.isfinite(np.diff(width, prepend=np.nan)) & (np.diff(idx, prepend=-2) == 1)
    c_idx = curv["frame_index"].to_numpy(np.int64) if "frame_index" in curv else np.zeros(0, int)
    out = {
        "fit": (
            lanes["frame_index"].to_numpy(np.int64),
            np.isfinite(lanes["cost"].to_numpy(float)),
        ),
        "width": (idx, np.isfinite(width)),
        "step": (idx, step_ok),
    }
    for source in CURVATURE_KPI_SOURCES:
        column = f"{source}_curvature"
        ok = (
            np.isfinite(curv[column].to_numpy(np.float64))
            if column in curv
            else np.zeros(len(c_idx), bool)
        )
        out[f"curvature_{source}"] = (c_idx, ok)
    return out


def _also(other: Produced | None, key: str, idx: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Return whether the other run produced ``key`` at each frame.

    All True without another run, or when it produced ``key`` nowhere on the drive: nothing to
    compare on, and the KPI is then lost by that run (its coverage says so), not 0 in both.
    """
    if other is None or not other[key][1].any():
        return np.ones(len(idx), bool)
    o_idx, o_ok = other[key]
    return np.isin(idx, o_idx[o_ok])


def _curvature_sums(
    curv: pd.DataFrame, source: str, reference: str, valid: str | None, both: NDArray[np.bool_]
) -> tuple[NDArray[np.int64], FloatArray, FloatArray, FloatArray]:
    """Return frame index, squared error, frames counted, and frames counted for this run alone.

    A frame counts with both values (estimate and reference) and the other run's estimate.
    """
    column, ref_col = f"{source}_curvature", f"{reference}_curvature"
    index = curv["frame_index"].to_numpy(np.int64) if "frame_index" in curv else np.zeros(0, int)
    if column not in curv or ref_col not in curv:
        zero = np.zeros(len(index))
        return index, zero, zero, zero
    est = curv[column].to_numpy(np.float64)
    ref = curv[ref_col].to_numpy(np.float64)
    ok = np.isfinite(est) & np.isfinite(ref)
    if valid is not None and valid in curv:
        ok &= curv[valid].to_numpy(bool)
    own = ok.astype(np.float64)
    ok &= both
    err = np.where(ok, est - ref, 0.0)
    return index, err * err, ok.astype(np.float64), own


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


def sequence_kpis(tables: DriveTables, other: DriveTables | None = None) -> pd.DataFrame:
    """Return the drive's per-sequence KPI sums: one row per sequence and KPI.

    Columns: ``sequence``, ``start``, ``stop``, ``start_ns``, ``category``, ``kpi``, ``num``,
    ``den`` (see the module docstring; ``den`` 0: no value) and ``measured`` (``den`` before
    the conditional KPIs are restricted to frames both runs produced).

    Args:
        tables: The run's tables.
        other: The other run's tables of the same drive: conditional KPIs count only frames
            both runs produced (without it, every frame this run produced).
    """
    seqs = sequences(tables)
    per_kpi: dict[str, tuple[FloatArray, FloatArray, FloatArray]] = {}
    starts = seqs["start"].to_numpy(np.int64)
    stops = seqs["stop"].to_numpy(np.int64)
    n = len(seqs)
    for name, (num, den) in _availability_kpis(tables, seqs).items():
        per_kpi[name] = (num, den, den)
    theirs = produced(other) if other is not None else None
    curv = tables.curvature
    for source in CURVATURE_KPI_SOURCES:
        c_idx = (
            curv["frame_index"].to_numpy(np.int64) if "frame_index" in curv else np.zeros(0, int)
        )
        both = _also(theirs, f"curvature_{source}", c_idx)
        for family, ref, valid in (
            ("curvature_rmse_truth", "rtk", "rtk_valid"),
            ("curvature_rmse_dynamics", "dynamics", None),
        ):
            idx, sq, ok, own = _curvature_sums(curv, source, ref, valid, both)
            per_kpi[f"{family}.{source}"] = (
                range_sums(idx, sq, starts, stops),
                range_sums(idx, ok, starts, stops),
                range_sums(idx, own, starts, stops),
            )
    per_kpi |= _width_kpis(tables, starts, stops, theirs)
    per_kpi |= _fit_kpis(tables, starts, stops, theirs)
    per_kpi |= _coverage_kpis(tables, starts, stops)
    order = [k.name for k in KPIS]
    per_kpi = {k: per_kpi[k] for k in order}
    out = {c: np.tile(seqs[c].to_numpy(), len(per_kpi)) for c in SEQUENCE_COLUMNS}
    out["kpi"] = np.repeat(np.array(list(per_kpi), dtype=object), n)
    for j, column in enumerate(("num", "den", "measured")):
        out[column] = np.concatenate([v[j] for v in per_kpi.values()]) if n else np.zeros(0)
    return pd.DataFrame(out)  # KPI order: that of KPIS


def _availability_kpis(
    tables: DriveTables, seqs: pd.DataFrame
) -> dict[str, tuple[FloatArray, FloatArray]]:
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
    per_kpi: dict[str, tuple[FloatArray, FloatArray]] = {}
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
    return per_kpi


def _width_kpis(
    tables: DriveTables,
    starts: NDArray[np.int64],
    stops: NDArray[np.int64],
    theirs: Produced | None,
) -> dict[str, tuple[FloatArray, FloatArray, FloatArray]]:
    idx, super_w = _width(tables, "super")
    me_idx, me_w = _width(tables, "mobileye")
    me_series = pd.Series(me_w, index=me_idx)
    me = me_series[~me_series.index.duplicated()].reindex(idx).to_numpy(np.float64)
    both = np.isfinite(super_w) & np.isfinite(me)
    diff = np.where(both, super_w - me, 0.0)
    step = np.diff(super_w, prepend=np.nan)
    own_step = np.isfinite(step) & (np.diff(idx, prepend=-2) == 1)
    ok_step = own_step & _also(theirs, "step", idx)
    step2 = np.where(ok_step, step * step, 0.0)
    inner = starts + 1  # a step into a sequence's first frame belongs to the one before
    bias_den = range_sums(idx, both.astype(np.float64), starts, stops)
    return {
        "lane_width_bias": (range_sums(idx, diff, starts, stops), bias_den, bias_den),
        "lane_width_jitter": (
            range_sums(idx, step2, inner, stops),
            range_sums(idx, ok_step.astype(np.float64), inner, stops),
            range_sums(idx, own_step.astype(np.float64), inner, stops),
        ),
    }


def _fit_kpis(
    tables: DriveTables,
    starts: NDArray[np.int64],
    stops: NDArray[np.int64],
    theirs: Produced | None,
) -> dict[str, tuple[FloatArray, FloatArray, FloatArray]]:
    lanes, frames = tables.lanes, tables.frames
    idx = lanes["frame_index"].to_numpy(np.int64)
    pair: FloatArray = np.asarray(
        ((lanes["ego_left"] >= 0) & (lanes["ego_right"] >= 0)).to_numpy(), dtype=np.float64
    )
    cost = lanes["cost"].to_numpy(np.float64)
    own = np.isfinite(cost)
    has_cost = own & _also(theirs, "fit", idx)
    clipped = np.where(has_cost, np.clip(cost, -FIT_COST_CLIP_J, FIT_COST_CLIP_J), 0.0)
    f_idx = frames["frame_index"].to_numpy(np.int64)
    stages = [c for c in frames.columns if c.endswith("_cpu_ms")]  # stage thread CPU time
    stage_s = frames[stages].fillna(0.0).to_numpy(np.float64).sum(axis=1) / 1e3
    n_frames = range_sums(idx, np.ones(len(idx)), starts, stops)
    n_timed = range_sums(f_idx, np.ones(len(f_idx)), starts, stops)
    cpu = range_sums(f_idx, stage_s, starts, stops)
    return {
        "ego_pair_share": (range_sums(idx, pair, starts, stops), n_frames, n_frames),
        "fit_cost": (
            range_sums(idx, clipped, starts, stops),
            range_sums(idx, has_cost.astype(np.float64), starts, stops),
            range_sums(idx, own.astype(np.float64), starts, stops),
        ),
        "frames_per_s": (n_timed, cpu, cpu),
    }


def _coverage_kpis(
    tables: DriveTables, starts: NDArray[np.int64], stops: NDArray[np.int64]
) -> dict[str, tuple[FloatArray, FloatArray, FloatArray]]:
    out = {}
    mine = produced(tables)
    for name in COVERAGE_KPIS:
        idx, ok = mine[name.partition(".")[2]]
        den = range_sums(idx, np.ones(len(idx)), starts, stops)
        out[name] = (range_sums(idx, ok.astype(np.float64), starts, stops), den, den)
    return out
