"""Paper-style tables over many reprocess runs: availability (corridor paper Table II), curvature.

Inputs are run folders written by ``slt reprocess`` (their ``availability_sequences`` and
``curvature_summary`` tables, named in ``reporting.layout``). Outputs are Markdown, LaTeX
or Parquet (with provenance).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.layout import AVAILABILITY_SEQUENCES_TABLE, CURVATURE_SUMMARY_TABLE
from superlane_tools.reporting.names import AVAILABILITY_NAMES, UNCATEGORISED, curvature_name
from superlane_tools.reporting.parquet import read_provenance, write_table
from superlane_tools.reporting.provenance import Provenance, input_identity
from superlane_tools.reporting.report import latex_table, markdown_table
from superlane_tools.reporting.run_folder import require_complete_run

METHOD_NAMES = AVAILABILITY_NAMES
TABLE_FORMATS = (".md", ".tex", ".parquet")


def _read(run_dir: Path, name: str) -> pd.DataFrame:
    path = run_dir / name
    if run_dir.is_dir() and path.is_file():
        require_complete_run(run_dir)
    if not path.is_file():
        raise OutputError(f"{run_dir}: not a reprocess run folder (missing {name})")
    read_provenance(path)
    return pd.read_parquet(path)


def _category(
    run_dir: Path, frame: pd.DataFrame, by: str, fallback: Mapping[str, str]
) -> pd.Series:
    """Group of each sequence: its run's name, or its category (never a run name)."""
    if by != "category":
        return pd.Series([run_dir.name] * len(frame), index=frame.index)
    default = fallback.get(run_dir.name, "") or UNCATEGORISED
    own = frame["category"].astype(str) if "category" in frame.columns else None
    if own is None:
        return pd.Series([default] * len(frame), index=frame.index)
    return own.where(own != "", default)


def availability_table(
    run_dirs: Sequence[Path], by: str = "run", categories: Mapping[str, str] | None = None
) -> pd.DataFrame:
    """Aggregate availability into Table II layout: one row per category (or run) plus total.

    With ``by="category"`` a sequence's own category wins; else its run's entry in
    ``categories`` (run folder name -> category, e.g. the batch manifest's), else
    :data:`UNCATEGORISED`.

    Columns: ``category``, ``#seq``, ``width at`` (the forward distance, m, at which every method
    measured its corridor width), then per method ``<method> n/N`` (frame-based ratio, %),
    ``<method> k/K`` (sequence-based ratio, %) and ``<method> width`` (median over the
    sequences' median widths, m); an unavailable method shows ``n/a``.

    Raises:
        OutputError: If a folder is not a reprocess run.
    """
    parts = []
    for run in run_dirs:
        seqs = _read(Path(run), AVAILABILITY_SEQUENCES_TABLE.file)
        group = _category(Path(run), seqs, by, categories or {})
        seqs = seqs.assign(group=group, run=Path(run).name)
        parts.append(seqs)
    if not parts:
        raise OutputError("no run folders given")
    allseq = pd.concat(parts, ignore_index=True)
    groups = [*dict.fromkeys(allseq["group"]), "total"]
    rows = []
    for group in groups:
        sel = allseq if group == "total" else allseq[allseq["group"] == group]
        row: dict[str, object] = {"category": group}
        row["#seq"] = len(sel[sel["method"] == "super"])
        if "width_at_m" in sel:  # runs written before the width distance was recorded lack it
            row["width at"] = ", ".join(f"{v:g} m" for v in sorted(set(sel["width_at_m"])))
        for method, label in METHOD_NAMES.items():
            m = sel[sel["method"] == method]
            if m.empty or not m["method_available"].any():
                row[f"{label} n/N"] = "n/a"
                row[f"{label} k/K"] = "n/a"
                row[f"{label} width"] = "n/a"
                continue
            n, big_n = int(m["n_available"].sum()), int(m["n_frames"].sum())
            k = int(m["available"].fillna(False).astype(bool).sum())
            row[f"{label} n/N"] = f"{100 * n / big_n:.1f}% ({n}/{big_n})"
            row[f"{label} k/K"] = f"{100 * k / len(m):.1f}% ({k}/{len(m)})"
            widths = (m["median_width_m"] if "median_width_m" in m else pd.Series([])).to_numpy(
                dtype=float
            )
            widths = widths[np.isfinite(widths)]
            row[f"{label} width"] = f"{np.median(widths):.2f} m" if widths.size else "n/a"
        rows.append(row)
    return pd.DataFrame(rows)


def _curvature_row(run: str, rec: Any) -> dict[str, object]:
    return {
        "run": run,
        "source": curvature_name(str(rec.source)),
        "n": int(rec.n),
        "coverage": float(rec.coverage),
        "rmse_per_m": float(rec.rmse),
        "mae_per_m": float(rec.mae),
        "bias_per_m": float(rec.bias),
        "correlation": float(rec.correlation),
    }


def curvature_table(run_dirs: Sequence[Path]) -> pd.DataFrame:
    """One row per run and source (SUPER, Mobileye): n, coverage, RMSE, MAE, bias, correlation."""
    rows: list[dict[str, object]] = []
    for run in run_dirs:
        summ = _read(Path(run), CURVATURE_SUMMARY_TABLE.file)
        overall = summ[summ["scope"] == "overall"]
        rows.extend(_curvature_row(Path(run).name, rec) for rec in overall.itertuples(index=False))
    if not rows:
        raise OutputError("no run folders given")
    return pd.DataFrame(rows)


def write_summary_table(
    frame: pd.DataFrame,
    out: str | os.PathLike[str],
    run_dirs: Sequence[Path],
    command: str = "",
) -> Path:
    """Write a table as ``.md``, ``.tex`` or ``.parquet`` (chosen by the suffix).

    Raises:
        OutputError: For another suffix.
    """
    path = Path(out)
    suffix = path.suffix.lower()
    if suffix == ".md":
        return write_text_atomic(path, markdown_table(frame) + "\n")
    if suffix == ".tex":
        return write_text_atomic(path, latex_table(frame))
    if suffix == ".parquet":
        inputs = tuple(
            input_identity(Path(r) / n)
            for r in run_dirs
            for n in (AVAILABILITY_SEQUENCES_TABLE.file, CURVATURE_SUMMARY_TABLE.file)
            if (Path(r) / n).is_file()
        )
        return write_table(
            frame.astype(str) if any(dt.kind == "O" for dt in frame.dtypes) else frame,
            path,
            Provenance(command=command, inputs=inputs),
        )
    raise OutputError(f"{path}: table format must be one of {', '.join(TABLE_FORMATS)}")
