"""Compare two fleets' KPIs: match drives, pool sequences, bootstrap the deltas, give verdicts.

Pure: sequence KPI sums in (:func:`superlane_tools.fleet.kpis.sequence_kpis`), one long table
out with a row per sequence, drive, category and the fleet for every KPI.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from superlane_tools.fleet.bootstrap import BootstrapParams, Delta, kpi_delta, paired_deltas
from superlane_tools.fleet.kpis import KPI_BY_NAME, KPIS
from superlane_tools.fleet.runs import DriveRun

SCOPES = ("fleet", "category", "drive", "sequence")
COLUMNS = (
    "scope",
    "drive",
    "sequence",
    "category",
    "start_ns",
    "kpi",
    "label",
    "unit",
    "higher_is_better",
    "base",
    "candidate",
    "delta",
    "ci_low",
    "ci_high",
    "n_sequences",
    "paired",
    "verdict",
)
"""Columns of the comparison table (``compare.parquet``); ``sequence`` is -1 and ``drive`` ""
above their scope; ``verdict`` is empty for single sequences (no interval for one sample)."""

DriveKpis = tuple[DriveRun, pd.DataFrame]
"""A drive and its per-sequence KPI sums."""


@dataclass(frozen=True)
class Comparison:
    """The result of comparing a base fleet with a candidate fleet.

    Attributes:
        table: One row per scope and KPI (see :data:`COLUMNS`).
        matched: ``(base, candidate)`` drive pairs of the same recording.
        only_base: Drives only the base covers (listed, left out of the paired deltas).
        only_candidate: Drives only the candidate covers.
        paired: Whether the fleet deltas are paired (some drives matched).
        params: The bootstrap settings used.
    """

    table: pd.DataFrame
    matched: tuple[tuple[DriveRun, DriveRun], ...]
    only_base: tuple[DriveRun, ...]
    only_candidate: tuple[DriveRun, ...]
    paired: bool
    params: BootstrapParams

    def fleet_rows(self) -> pd.DataFrame:
        """Return the fleet-scope rows, one per KPI."""
        return self.table[self.table["scope"] == "fleet"].reset_index(drop=True)


def _tagged(drive: DriveRun, seqs: pd.DataFrame) -> pd.DataFrame:
    cat = seqs["category"].astype(str)
    return seqs.assign(drive=drive.drive, category=cat.where(cat != "", drive.category))


def _row(
    scope: str,
    kpi: str,
    d: Delta,
    drive: str = "",
    sequence: int = -1,
    category: str = "",
    start_ns: int = 0,
) -> dict[str, object]:
    k = KPI_BY_NAME[kpi]
    return {
        "scope": scope,
        "drive": drive,
        "sequence": sequence,
        "category": category,
        "start_ns": start_ns,
        "kpi": kpi,
        "label": k.label,
        "unit": k.unit,
        "higher_is_better": k.higher_is_better,
        **d._asdict(),
    }


def _paired_rows(merged: pd.DataFrame, params: BootstrapParams) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    for kpi, g in merged.groupby("kpi", sort=False):
        k = KPI_BY_NAME[str(kpi)]
        nb, db = g["num_b"].to_numpy(np.float64), g["den_b"].to_numpy(np.float64)
        nc, dc = g["num_c"].to_numpy(np.float64), g["den_c"].to_numpy(np.float64)
        bv, cv = k.pooled(nb, db), k.pooled(nc, dc)
        for i, (drive, seq, cat, t0) in enumerate(
            zip(g["drive"], g["sequence"], g["category"], g["start_ns"], strict=True)
        ):
            one = Delta(
                float(bv[i]), float(cv[i]), float(cv[i] - bv[i]), np.nan, np.nan, 1, True, ""
            )
            rows.append(_row("sequence", str(kpi), one, str(drive), int(seq), str(cat), int(t0)))
        drives = list(g.groupby("drive", sort=False))
        pairs = [
            (
                (d["num_b"].to_numpy(np.float64), d["den_b"].to_numpy(np.float64)),
                (d["num_c"].to_numpy(np.float64), d["den_c"].to_numpy(np.float64)),
            )
            for _, d in drives
        ]
        for (drive, d), delta in zip(drives, paired_deltas(k, pairs, params), strict=True):
            rows.append(
                _row(
                    "drive",
                    str(kpi),
                    delta,
                    str(drive),
                    category=str(d["category"].iloc[0]),
                    start_ns=int(d["start_ns"].min()),
                )
            )
    return rows


def _pooled_rows(
    scope: str,
    groups: Sequence[tuple[str, pd.DataFrame, pd.DataFrame]],
    paired: bool,
    params: BootstrapParams,
) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    for name, base, cand in groups:
        for k in KPIS:
            if paired:
                sel = base[base["kpi"] == k.name]
                b = (sel["num_b"].to_numpy(np.float64), sel["den_b"].to_numpy(np.float64))
                c = (sel["num_c"].to_numpy(np.float64), sel["den_c"].to_numpy(np.float64))
            else:
                sb, sc = base[base["kpi"] == k.name], cand[cand["kpi"] == k.name]
                b = (sb["num"].to_numpy(np.float64), sb["den"].to_numpy(np.float64))
                c = (sc["num"].to_numpy(np.float64), sc["den"].to_numpy(np.float64))
            rows.append(
                _row(
                    scope,
                    k.name,
                    kpi_delta(k, b, c, paired, params),
                    category=name if scope == "category" else "",
                )
            )
    return rows


def compare_fleets(
    base: Sequence[DriveKpis], candidate: Sequence[DriveKpis], params: BootstrapParams
) -> Comparison:
    """Match the drives of two fleets and compare every KPI per sequence, drive, category, fleet.

    Drives match by key (same recording, same window); their sequences match by index and start
    time. With matched drives the deltas are paired over the matched sequences and unmatched
    drives are listed only; with none, each fleet's sequences are resampled on their own.
    """
    by_key = {d.key: (d, s) for d, s in candidate}
    matched, only_base = [], []
    parts = []
    for drive, seqs in base:
        other = by_key.pop(drive.key, None)
        if other is None:
            only_base.append(drive)
            continue
        matched.append((drive, other[0]))
        b = _tagged(drive, seqs).rename(columns={"num": "num_b", "den": "den_b"})
        c = other[1][["sequence", "start_ns", "kpi", "num", "den"]].rename(
            columns={"num": "num_c", "den": "den_c"}
        )
        parts.append(b.merge(c, on=["sequence", "start_ns", "kpi"], how="inner"))
    only_candidate = [d for d, _ in by_key.values()]
    paired = bool(matched)
    rows: list[dict[str, object]] = []
    if paired:
        merged = pd.concat(parts, ignore_index=True)
        groups = [("", merged, merged)]
        cats = [(str(c), g, g) for c, g in merged.groupby("category", sort=True)]
        rows += _pooled_rows("fleet", groups, True, params)
        rows += _pooled_rows("category", cats, True, params) if len(cats) > 1 else []
        rows += _paired_rows(merged, params)
    else:
        all_b = pd.concat([_tagged(d, s) for d, s in base], ignore_index=True)
        all_c = pd.concat([_tagged(d, s) for d, s in candidate], ignore_index=True)
        rows += _pooled_rows("fleet", [("", all_b, all_c)], False, params)
        names = sorted(set(all_b["category"]) & set(all_c["category"]))
        cats = [(c, all_b[all_b["category"] == c], all_c[all_c["category"] == c]) for c in names]
        rows += _pooled_rows("category", cats, False, params) if len(cats) > 1 else []
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    return Comparison(
        table, tuple(matched), tuple(only_base), tuple(only_candidate), paired, params
    )
