"""Fleet summary of an output root: status by category, availability, curvature, a report.

Built from ``batch_status.parquet`` and the per-recording Parquet tables that ``slt reprocess``
writes (``availability_sequences.parquet``, ``curvature.parquet``); runs of other job kinds
contribute to the status table only. Everything goes to ``ROOT/summary/``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.commands.batch.status import read_status
from superlane_tools.evaluation import curvature_errors
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import (
    AVAILABILITY_BY_CATEGORY_TABLE,
    AVAILABILITY_SEQUENCES_TABLE,
    CURVATURE_BY_RECORDING_TABLE,
    CURVATURE_SUMMARY_TABLE,
    CURVATURE_TABLE,
    FLEET_STATUS_TABLE,
    SUMMARY_DIR,
    SummaryLayout,
)
from superlane_tools.reporting.names import UNCATEGORISED
from superlane_tools.reporting.report import Section, write_report

TRUTH_COLUMN = "rtk_curvature"


def fleet_status(status: pd.DataFrame) -> pd.DataFrame:
    """Return recordings per category and outcome, with frames and processing time."""
    frame = status.assign(category=status["category"].replace("", UNCATEGORISED))
    # a skipped row reports the outcome of the run that produced its outputs
    frame = frame.assign(outcome=frame["result"].where(frame["result"] != "", frame["status"]))
    rows = []
    for category, group in frame.groupby("category", sort=True):
        rows.append(
            {
                "category": category,
                "recordings": len(group),
                "ok": int((group["outcome"] == "ok").sum()),
                "partial": int((group["outcome"] == "partial").sum()),
                "failed": int((group["outcome"] == "failed").sum()),
                "frames": int(group["frames"].sum()),
                "processing_s": float(group["total_s"].sum()),
            }
        )
    return pd.DataFrame(rows, columns=list(FLEET_STATUS_TABLE.columns))


def _done(root: Path, status: pd.DataFrame) -> pd.DataFrame:
    ok = status["result"].isin(["ok", "partial"])
    folder = status["recording_id"].map(lambda r: (root / r).is_dir()).astype(bool)  # empty too
    return status[ok & folder]


def availability_by_category(root: Path, status: pd.DataFrame) -> pd.DataFrame:
    """Availability per category and method over all finished runs (corridor paper Table II).

    Frame-based: available frames ``n`` over frames ``N``; sequence-based: available sequences
    ``k`` over sequences ``K``. A sequence's own category wins over the recording's.
    """
    parts = []
    for row in _done(root, status).itertuples(index=False):
        path = root / str(row.recording_id) / AVAILABILITY_SEQUENCES_TABLE.file
        if not path.is_file():
            continue
        seqs = pd.read_parquet(path)
        if seqs.empty:
            continue
        own = seqs["category"].astype(str) if "category" in seqs else pd.Series("", seqs.index)
        fallback = str(row.category) or UNCATEGORISED
        seqs = seqs.assign(category=own.where(own != "", fallback))
        seqs["recording_id"] = str(row.recording_id)
        parts.append(seqs)
    columns = list(AVAILABILITY_BY_CATEGORY_TABLE.columns)
    if not parts:
        return pd.DataFrame(columns=columns)
    seqs = pd.concat(parts, ignore_index=True)
    rows = []
    for (category, method), group in seqs.groupby(["category", "method"], sort=True):
        n, big_n = int(group["n_available"].sum()), int(group["n_frames"].sum())
        available = group["available"].astype("boolean")
        k, big_k = int(available.fillna(False).sum()), len(group)
        method_ok = bool(group["method_available"].all()) if "method_available" in group else True
        rows.append(
            {
                "category": category,
                "method": method,
                "recordings": group["recording_id"].nunique(),
                "sequences": big_k,
                "n": n,
                "N": big_n,
                "frame_ratio": n / big_n if big_n else math.nan,
                "k": k,
                "K": big_k,
                "sequence_ratio": k / big_k if big_k else math.nan,
                "method_available": method_ok,
            }
        )
    return pd.DataFrame(rows, columns=columns)


def curvature_by_recording(root: Path, status: pd.DataFrame) -> pd.DataFrame:
    """Curvature errors (1/m) against RTK of every estimate column, per finished recording."""
    rows = []
    for row in _done(root, status).itertuples(index=False):
        path = root / str(row.recording_id) / CURVATURE_TABLE.file
        if not path.is_file():
            continue
        curv = pd.read_parquet(path)
        if TRUTH_COLUMN not in curv:
            continue
        truth = curv[TRUTH_COLUMN].to_numpy(dtype=np.float64)
        sources = [c for c in curv.columns if c.endswith("_curvature") and c != TRUTH_COLUMN]
        for column in sources:
            err = curvature_errors(curv[column].to_numpy(dtype=np.float64), truth)
            rows.append(
                {
                    "recording_id": row.recording_id,
                    "category": str(row.category) or UNCATEGORISED,
                    "source": column.removesuffix("_curvature"),
                    **err._asdict(),
                }
            )
    return pd.DataFrame(rows, columns=list(CURVATURE_BY_RECORDING_TABLE.columns))


def _sections(
    status: pd.DataFrame, fleet: pd.DataFrame, avail: pd.DataFrame, curv: pd.DataFrame
) -> list[tuple[str, pd.DataFrame, str]]:
    failed = status[status["result"] == "failed"][["recording_id", "recording", "error"]]
    return [
        ("Recordings by category", fleet, ""),
        (
            "Availability by category",
            avail,
            "n/N: available frames over frames; k/K: available sequences over sequences.",
        ),
        ("Curvature errors by recording (1/m, against RTK)", curv, ""),
        ("Failed recordings", failed, ""),
    ]


def _paper_tables(root: Path, status: pd.DataFrame) -> list[tuple[str, pd.DataFrame, str]]:
    """The ``slt tables`` layouts (corridor paper Table II, curvature) over reprocess runs."""
    from superlane_tools.commands.tables import availability_table, curvature_table
    from superlane_tools.reporting import OutputError

    done = _done(root, status)
    runs = [root / str(r) for r in done["recording_id"]]
    categories = dict(
        zip(done["recording_id"].astype(str), done["category"].astype(str), strict=True)
    )
    sections = []
    with_avail = [r for r in runs if (r / AVAILABILITY_SEQUENCES_TABLE.file).is_file()]
    with_curv = [r for r in runs if (r / CURVATURE_SUMMARY_TABLE.file).is_file()]
    try:
        if with_avail:
            table = availability_table(with_avail, by="category", categories=categories)
            sections.append(("Availability, corridor paper Table II layout", table, ""))
        if with_curv:
            sections.append(
                ("Curvature per run (slt tables curvature)", curvature_table(with_curv), "")
            )
    except OutputError as err:  # a run folder of another kind: keep the plain tables
        sections.append(("Paper tables unavailable", pd.DataFrame({"reason": [str(err)]}), ""))
    return sections


def _report(
    out: Path,
    sections: Sequence[tuple[str, pd.DataFrame, str]],
    title: str,
    extra: Sequence[Section] = (),
) -> list[Path]:
    """Write ``report.md`` and ``report.html`` with one table per section, then ``extra``."""
    return write_report(
        SummaryLayout(out).report,
        title,
        [Section(heading, [note] if note else [], [frame]) for heading, frame, note in sections]
        + list(extra),
    )


def write_summary(root: str | Path, command: str = "", extra: Sequence[Section] = ()) -> list[Path]:
    """Write ``ROOT/summary/``: Parquet tables plus ``report.md`` and ``report.html``.

    ``extra``: report sections appended after the fleet's own (the nightly comparison with a
    baseline and the mined frames, ``pipelines/nightly.py --baseline``).

    Returns:
        The files written.
    """
    base = Path(root)
    out = base / SUMMARY_DIR
    layout = SummaryLayout(out)
    status = read_status(base)
    fleet = fleet_status(status)
    avail = availability_by_category(base, status)
    curv = curvature_by_recording(base, status)
    provenance = Provenance(command=command or "slt batch", config={"root": str(base)})
    written = [
        write_table(fleet, layout.fleet_status, provenance),
        write_table(avail, layout.availability_by_category, provenance),
        write_table(curv, layout.curvature_by_recording, provenance),
    ]
    sections = _sections(status, fleet, avail, curv)
    sections[2:2] = _paper_tables(base, status)
    total = len(status)
    title = f"Fleet summary: {total} recording{'s' if total != 1 else ''} in {base.name}"
    written += _report(out, sections, title, extra)
    return written
