"""The report's opening table: one number per method and quantity, the truth's noise floor."""

from __future__ import annotations

import math

import pandas as pd

from superlane_tools.reporting.names import AVAILABILITY_NAMES, CURVATURE_NAMES

HEADLINE_CURVATURE = ("super_path", "super", "mobileye_path", "mobileye", "dynamics")
"""Curvature sources in the headline, in order."""
AVAILABILITY_OF = {"super_path": "super", "super": "super", "mobileye": "mobileye"}
"""Curvature source -> availability method shown on the same row."""


def headline_table(
    summary: pd.DataFrame, sequences: pd.DataFrame, noise_floor_per_m: float
) -> pd.DataFrame:
    """Return one row per method: curvature RMSE against the truth and availability.

    Args:
        summary: ``curvature_summary`` rows (``scope``, ``source``, ``n``, ``rmse``).
        sequences: ``availability_sequences`` rows (``method``, ``n_frames``,
            ``n_available``, ``available``, ``method_available``).
        noise_floor_per_m: The truth's own curvature noise floor, 1/m (NaN unknown).

    Returns:
        Columns ``method``, ``curvature RMSE (1/m)``, ``truth noise floor (1/m)``,
        ``frames compared``, ``frames available``, ``sequences available``.
    """
    overall = summary[summary["scope"] == "overall"] if len(summary) else summary
    rows: list[dict[str, object]] = []
    shown: set[str] = set()
    for source in HEADLINE_CURVATURE:
        rec = overall[overall["source"] == source] if len(overall) else overall
        method = AVAILABILITY_OF.get(source, "")
        if source == "mobileye_path":
            method = ""  # the same Mobileye availability is on the raw row
        rows.append(_row(CURVATURE_NAMES[source], rec, sequences, method, noise_floor_per_m))
        shown.add(method)
    rows.extend(
        _row(AVAILABILITY_NAMES[method], None, sequences, method, noise_floor_per_m)
        for method in ("corridor_net", "hough")
        if method not in shown
    )
    return pd.DataFrame(rows)


def _row(
    name: str,
    rec: pd.DataFrame | None,
    sequences: pd.DataFrame,
    method: str,
    floor: float,
) -> dict[str, object]:
    rmse = math.nan
    n = 0
    if rec is not None and len(rec):
        rmse = float(rec["rmse"].iloc[0])
        n = int(rec["n"].iloc[0])
    frames = seqs = "-"
    if method and len(sequences):
        sel = sequences[sequences["method"] == method]
        if len(sel) and bool(sel["method_available"].any()):
            big_n = int(sel["n_frames"].sum())
            frames = f"{100 * int(sel['n_available'].sum()) / max(big_n, 1):.1f}%"
            decided = sel["available"].fillna(False).astype(bool)
            seqs = f"{int(decided.sum())}/{len(sel)}"
        elif len(sel):
            frames = seqs = "not run"
    return {
        "method": name,
        "curvature RMSE (1/m)": rmse if rec is not None else "-",
        "truth noise floor (1/m)": floor if rec is not None else "-",
        "frames compared": n if rec is not None else "-",
        "frames available": frames,
        "sequences available": seqs,
    }
