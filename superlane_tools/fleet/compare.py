"""Compare two fleets' KPIs: match drives and sequences, pool per drive, intervals over drives.

Pure: sequence KPI sums in (:func:`superlane_tools.fleet.kpis.sequence_kpis`), one long table
out with a row per sequence, drive, category and the fleet for every KPI. The drive is the
unit: a sequence counts for a KPI where both runs have a value there, a drive's sums are its
matched sequences' sums, and the fleet's (or a category's) interval resamples drives
(:mod:`superlane_tools.fleet.bootstrap`). One drive's numbers are descriptive.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from superlane_tools.fleet.bootstrap import (
    DESCRIPTIVE,
    LOST,
    UNAVAILABLE,
    UNPAIRED,
    BootstrapParams,
    Delta,
    FloatArray,
    describe,
    drive_delta,
)
from superlane_tools.fleet.kpis import KPI_BY_NAME, KPIS, Kpi
from superlane_tools.fleet.runs import DriveRun
from superlane_tools.reporting.layout import COMPARE_TABLE

SCOPES = ("fleet", "category", "drive", "sequence")
COLUMNS = COMPARE_TABLE.columns
"""Columns of the comparison table (``compare.parquet``, declared by its spec; the last are
:class:`Delta`'s fields); ``sequence`` is -1 and ``drive`` "" above their scope;
``ci_low``/``ci_high``/``p_value`` NaN where no interval is drawn."""

DriveKpis = tuple[DriveRun, pd.DataFrame]
"""A drive and its per-sequence KPI sums."""
_SUMS = ("num_b", "den_b", "num_c", "den_c", "own_b", "raw_b", "raw_c", "both")


@dataclass(frozen=True)
class Comparison:
    """The result of comparing a base fleet with a candidate fleet.

    Attributes:
        table: One row per scope and KPI (see :data:`COLUMNS`).
        matched: ``(base, candidate)`` drive pairs of the same recording with matched sequences.
        only_base: Drives only the base covers (listed, left out of the deltas).
        only_candidate: Drives only the candidate covers.
        paired: Whether the fleet deltas are paired (some drives matched).
        params: The bootstrap settings used.
        unaligned: Pairs of the same recording whose sequences do not line up (another
            ``kpi.window_s``): left out.
        sequences: Matched sequences, and the base's and candidate's sequences in all.
        margins: The margin used per KPI (the KPI's default or as configured).
    """

    table: pd.DataFrame
    matched: tuple[tuple[DriveRun, DriveRun], ...]
    only_base: tuple[DriveRun, ...]
    only_candidate: tuple[DriveRun, ...]
    paired: bool
    params: BootstrapParams
    unaligned: tuple[tuple[DriveRun, DriveRun], ...] = ()
    sequences: tuple[int, int, int] = (0, 0, 0)
    margins: Mapping[str, float] = field(default_factory=dict)

    def fleet_rows(self) -> pd.DataFrame:
        """Return the fleet-scope rows, one per KPI."""
        return self.table[self.table["scope"] == "fleet"].reset_index(drop=True)

    def n_drives(self) -> tuple[int, int, int]:
        """Return matched drives, and the base's and candidate's drives in all."""
        n_b = len(self.matched) + len(self.unaligned) + len(self.only_base)
        n_c = len(self.matched) + len(self.unaligned) + len(self.only_candidate)
        return len(self.matched), n_b, n_c


def _tagged(drive: DriveRun, seqs: pd.DataFrame) -> pd.DataFrame:
    cat = seqs["category"].astype(str)
    return seqs.assign(drive=drive.drive, category=cat.where(cat != "", drive.category))


def _row(scope: str, kpi: str, d: Delta, **where: object) -> dict[str, object]:
    k = KPI_BY_NAME[kpi]
    row: dict[str, object] = {"scope": scope, "drive": "", "sequence": -1, "category": ""}
    row |= {"start_ns": 0, **where, "kpi": kpi, "label": k.label, "unit": k.unit}
    return row | {"higher_is_better": k.higher_is_better, **d._asdict()}


def _merge(b: pd.DataFrame, c: pd.DataFrame) -> pd.DataFrame:
    """Join the drives' sequences of both runs; a sequence counts where both have a value.

    Rows join by ``pair`` (the matched drive pair), sequence index, start time and KPI.
    """
    left = b.rename(columns={"num": "num_b", "den": "den_b", "measured": "raw_b"})
    right = c[["pair", "sequence", "start_ns", "kpi", "num", "den", "measured"]].rename(
        columns={"num": "num_c", "den": "den_c", "measured": "raw_c"}
    )
    merged = left.merge(right, on=["pair", "sequence", "start_ns", "kpi"], how="inner")
    both = (merged["den_b"] > 0) & (merged["den_c"] > 0)
    merged["own_b"] = merged["num_b"]  # the base's own value, shown when the candidate lost it
    merged["both"] = both.astype(np.float64)
    for column in ("num_b", "den_b", "num_c", "den_c"):
        merged[column] = merged[column].where(both, 0.0)
    return merged


def drive_sums(merged: pd.DataFrame) -> pd.DataFrame:
    """Return each drive's sums per KPI (a per-drive ``abs`` KPI: ``|sum num|``)."""
    sums = merged.groupby(["kpi", "drive"], sort=False)[list(_SUMS)].sum()
    cats = merged.groupby(["kpi", "drive"], sort=False)[["category", "start_ns"]].agg(
        {"category": "first", "start_ns": "min"}
    )
    out = sums.join(cats).reset_index()
    absolute = out["kpi"].map(lambda k: KPI_BY_NAME[str(k)].per_drive == "abs").astype(bool)
    for column in ("num_b", "num_c", "own_b"):
        out.loc[absolute, column] = out.loc[absolute, column].abs()
    return out


def _fleet_delta(
    k: Kpi, g: pd.DataFrame, params: BootstrapParams, margin: float | None, n_seq: int
) -> Delta:
    b = (g["num_b"].to_numpy(np.float64), g["den_b"].to_numpy(np.float64))
    c = (g["num_c"].to_numpy(np.float64), g["den_c"].to_numpy(np.float64))
    if g["raw_b"].sum() > 0 and g["raw_c"].sum() == 0:
        own = (g["own_b"].to_numpy(np.float64), g["raw_b"].to_numpy(np.float64))
        lost = describe(k, own, c, LOST)
        return lost._replace(n_sequences=n_seq)
    return drive_delta(k, b, c, params, margin, n_seq)


def _described(scope: str, k: Kpi, g: pd.DataFrame, default: str) -> pd.DataFrame:
    """Return values and deltas without an interval, one row per row of ``g`` (drive, sequence)."""

    def col(name: str) -> FloatArray:
        return g[name].to_numpy(np.float64)

    lost = (col("raw_b") > 0) & (col("raw_c") == 0)
    nb, db = np.where(lost, col("own_b"), col("num_b")), np.where(lost, col("raw_b"), col("den_b"))
    nc = col("num_c")
    if scope == "sequence" and k.per_drive == "abs":
        nb, nc = np.abs(nb), np.abs(nc)
    bv, cv = k.pooled(nb, db), k.pooled(nc, col("den_c"))
    verdict = np.where(np.isnan(bv), UNAVAILABLE, np.where(lost, LOST, default))
    margin = k.relative_margin * np.abs(bv) if k.relative_margin else np.full(len(g), k.margin)
    n = len(g)
    return pd.DataFrame(
        {
            "scope": scope,
            "drive": g["drive"].to_numpy(),
            "sequence": g["sequence"].to_numpy(np.int64) if scope == "sequence" else -1,
            "category": g["category"].to_numpy(),
            "start_ns": g["start_ns"].to_numpy(np.int64),
            "kpi": k.name,
            "label": k.label,
            "unit": k.unit,
            "higher_is_better": k.higher_is_better,
            "base": bv,
            "candidate": cv,
            "delta": cv - bv,
            "ci_low": np.full(n, np.nan),
            "ci_high": np.full(n, np.nan),
            "n_sequences": col("both").astype(np.int64),
            "n_drives": 1,
            "paired": True,
            "p_value": np.full(n, np.nan),
            "margin": margin,
            "note": "",
            "verdict": verdict,
        },
        columns=list(COLUMNS),
    )


def _scoped_rows(
    drives: pd.DataFrame, params: BootstrapParams, margins: Mapping[str, float]
) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    groups = [("fleet", "", drives)]
    cats = sorted(set(drives["category"]))
    if len(cats) > 1:
        groups += [("category", c, drives[drives["category"] == c]) for c in cats]
    for scope, cat, d_all in groups:
        for kpi, g in d_all.groupby("kpi", sort=False):
            k = KPI_BY_NAME[str(kpi)]
            delta = _fleet_delta(k, g, params, margins.get(k.name), int(g["both"].sum()))
            rows.append(_row(scope, k.name, delta, category=cat))
    return rows


def _unscoped(frame: pd.DataFrame, scope: str, default: str) -> list[pd.DataFrame]:
    return [
        _described(scope, KPI_BY_NAME[str(kpi)], g, default)
        for kpi, g in frame.groupby("kpi", sort=False)
    ]


def _unpaired_rows(
    base: Sequence[DriveKpis], candidate: Sequence[DriveKpis]
) -> list[dict[str, object]]:
    all_b = pd.concat([s for _, s in base], ignore_index=True)
    all_c = pd.concat([s for _, s in candidate], ignore_index=True)
    rows = []
    for k in KPIS:
        sb, sc = all_b[all_b["kpi"] == k.name], all_c[all_c["kpi"] == k.name]
        b = (sb["num"].to_numpy(np.float64), sb["den"].to_numpy(np.float64))
        c = (sc["num"].to_numpy(np.float64), sc["den"].to_numpy(np.float64))
        if k.per_drive == "abs":
            b, c = (np.abs(b[0]), b[1]), (np.abs(c[0]), c[1])
        one = describe(k, b, c, UNPAIRED, paired=False)
        rows.append(_row("fleet", k.name, one._replace(n_drives=0, n_sequences=0)))
    return rows


def compare_fleets(
    base: Sequence[DriveKpis],
    candidate: Sequence[DriveKpis],
    params: BootstrapParams,
    margins: Mapping[str, float] | None = None,
) -> Comparison:
    """Match the drives of two fleets and compare every KPI per sequence, drive, category, fleet.

    Drives match by key (same recording, same window); their sequences match by index and start
    time. The deltas are paired over the matched drives (intervals over drives); unmatched
    drives, and matched ones whose sequences do not line up, are listed only. With no matched
    drive the fleets' values are shown side by side, unpaired, without a verdict.

    Args:
        base: The base's drives and their sequence KPIs.
        candidate: The candidate's.
        params: Interval settings.
        margins: Margins per KPI name, in the KPI's unit (default: the KPI's).
    """
    margins = dict(margins or {})
    by_key = {d.key: (d, s) for d, s in candidate}
    matched: list[tuple[DriveRun, DriveRun]] = []
    unaligned: list[tuple[DriveRun, DriveRun]] = []
    only_base: list[DriveRun] = []
    parts: list[pd.DataFrame] = []
    pairs: list[tuple[DriveRun, DriveRun]] = []
    right: list[pd.DataFrame] = []
    for drive, seqs in base:
        other = by_key.pop(drive.key, None)
        if other is None:
            only_base.append(drive)
            continue
        parts.append(_tagged(drive, seqs).assign(pair=len(pairs)))
        right.append(other[1].assign(pair=len(pairs)))
        pairs.append((drive, other[0]))
    only_candidate = [d for d, _ in by_key.values()]
    seqs = _merge(pd.concat(parts), pd.concat(right)) if pairs else pd.DataFrame()
    lined_up = set(seqs["pair"]) if pairs else set()
    for i, pair in enumerate(pairs):
        (matched if i in lined_up else unaligned).append(pair)
    n_seq_b = sum(s["sequence"].nunique() for _, s in base)
    n_seq_c = sum(s["sequence"].nunique() for _, s in candidate)
    n_matched = int(seqs.groupby(["pair", "sequence"]).ngroups) if len(seqs) else 0
    if matched:
        drives = drive_sums(seqs)
        parts_out = [pd.DataFrame(_scoped_rows(drives, params, margins), columns=list(COLUMNS))]
        parts_out += _unscoped(drives, "drive", DESCRIPTIVE)
        parts_out += _unscoped(seqs, "sequence", "")
        table = pd.concat(parts_out, ignore_index=True)
    else:
        table = pd.DataFrame(_unpaired_rows(base, candidate), columns=list(COLUMNS))
    used = {k.name: margins.get(k.name, k.margin) for k in KPIS}
    return Comparison(
        table,
        tuple(matched),
        tuple(only_base),
        tuple(only_candidate),
        bool(matched),
        params,
        tuple(unaligned),
        (n_matched, n_seq_b, n_seq_c),
        used,
    )
