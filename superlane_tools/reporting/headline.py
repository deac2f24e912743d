"""The report's opening table: one number per method and quantity, the truth's noise floor."""

from __future__ import annotations

import math

import pandas as pd

from superlane_tools.reporting.drive_facts import DriveFacts
from superlane_tools.reporting.names import AVAILABILITY_NAMES, CURVATURE_NAMES

HEADLINE_CURVATURE = ("super_path", "super", "mobileye_path", "mobileye", "dynamics")
"""Curvature sources in the headline, in order."""
AVAILABILITY_OF = {"super_path": "super", "super": "super", "mobileye": "mobileye"}
"""Curvature source -> availability method shown on the same row."""


def headline_table(
    summary: pd.DataFrame,
    sequences: pd.DataFrame,
    noise_floor_per_m: float,
    facts: DriveFacts | None = None,
) -> pd.DataFrame:
    """Return one row per method that ran: curvature RMSE against the truth and availability.

    Args:
        summary: ``curvature_summary`` rows (``scope``, ``source``, ``n``, ``rmse``).
        sequences: ``availability_sequences`` rows (``method``, ``n_frames``,
            ``n_available``, ``n_unknown``, ``available``, ``method_available``).
        noise_floor_per_m: The truth's own curvature noise floor, 1/m (NaN unknown).
        facts: What the drive had: sources and methods that did not run are left out, and the
            curvature cells say ``no truth`` without one (None: every row, as the tables say).

    Returns:
        Columns ``method``, ``curvature RMSE (1/m)`` (flagged where below the noise floor:
        not resolvable), ``frames compared``, ``frames available``, ``sequences available``.
        Frames whose availability is unknown (no speed) are counted apart: ``unknown (no
        speed)`` when all are, else the share of available frames among all with the unknown
        count beside it.
        Without a truth the table has one row per method that ran and says ``no truth`` in
        place of the curvature columns.
    """
    overall = summary[summary["scope"] == "overall"] if len(summary) else summary
    sources = facts.curvature_sources_run() if facts is not None else HEADLINE_CURVATURE
    methods = facts.methods_run() if facts is not None else tuple(AVAILABILITY_NAMES)
    no_truth = facts is not None and not facts.truth_instants
    if no_truth:  # one row per method that ran; no curvature numbers without a truth
        cells = [
            _row(AVAILABILITY_NAMES[m], None, sequences, m, noise_floor_per_m) for m in methods
        ]
        table = pd.DataFrame(cells, columns=["method", *AVAILABILITY_COLUMNS])
        table.insert(1, "curvature RMSE (1/m)", "no truth")
        return table
    rows: list[dict[str, object]] = []
    shown: set[str] = set()
    for source in HEADLINE_CURVATURE:
        if source not in sources:
            continue
        rec = overall[overall["source"] == source] if len(overall) else overall
        method = AVAILABILITY_OF.get(source, "")
        if source == "mobileye_path" or method in shown:
            method = ""  # the same availability is on the row above
        rows.append(_row(CURVATURE_NAMES[source], rec, sequences, method, noise_floor_per_m))
        shown.add(method)
    rows.extend(
        _row(AVAILABILITY_NAMES[method], None, sequences, method, noise_floor_per_m)
        for method in ("corridor_net", "hough")
        if method not in shown and method in methods
    )
    return pd.DataFrame(rows, columns=["method", *CURVATURE_COLUMNS, *AVAILABILITY_COLUMNS])


CURVATURE_COLUMNS = ("curvature RMSE (1/m)", "frames compared")
"""The truth's noise floor is one value per drive: the headline states it once, not per row."""
AVAILABILITY_COLUMNS = ("frames available", "sequences available")


def below_floor(rmse: float, floor: float) -> bool:
    """Whether an RMSE lies below the truth's own noise floor (cannot be resolved)."""
    return math.isfinite(rmse) and math.isfinite(floor) and rmse < floor


def rmse_cell(rmse: float, floor: float) -> float | str:
    """The RMSE, or the RMSE flagged as not resolvable when it is below the noise floor."""
    if below_floor(rmse, floor):
        return f"{rmse:.3g} (below the truth's noise floor {floor:.3g}: not resolvable)"
    return rmse


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
            frames, seqs = _availability_cells(sel)
        elif len(sel):
            frames = seqs = "not run"
    return {
        "method": name,
        "curvature RMSE (1/m)": rmse_cell(rmse, floor) if rec is not None else "-",
        "frames compared": n if rec is not None else "-",
        "frames available": frames,
        "sequences available": seqs,
    }


def _availability_cells(sel: pd.DataFrame) -> tuple[str, str]:
    """Frames and sequences available of one method, keeping unknown apart from unavailable."""
    big_n = int(sel["n_frames"].sum())
    n_av = int(sel["n_available"].sum())
    unknown = int(sel["n_unknown"].sum()) if "n_unknown" in sel else 0
    decided = sel["available"]
    n_decided = int(decided.notna().sum())
    k = int(decided.fillna(False).astype(bool).sum())
    if big_n and unknown >= big_n:
        return "unknown (no speed)", "unknown (no speed)"
    frames = f"{100 * n_av / max(big_n, 1):.1f}%"
    if unknown:
        frames += f" ({unknown} of {big_n} frames unknown)"
    if not n_decided:
        return frames, "unknown (decided by unknown frames)"
    seqs = f"{k}/{len(sel)}"
    if n_decided < len(sel):
        seqs += f" ({len(sel) - n_decided} undecided: unknown frames)"
    return frames, seqs
