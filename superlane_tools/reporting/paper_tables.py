"""The SUPER paper's tables from saved evaluation results: Table 2, 3, 4 and the Fig. 9 modes.

Every ``slt eval ... --save RESULT.json`` writes one *evaluation record*: the metric kind, the
cell it fills (``row``, ``column``), the numbers, the exact command line, and the identity
(name, size, SHA-256) of the prediction and ground-truth files. ``slt tables paper RESULT...``
lays the records out as the paper does:

* **Table 2** (``tusimple``, mode ``all``): TuSimple accuracy; rows ``no sq`` / ``sq``, columns
  ``no sc`` / ``sc`` (or any other method name); a record scored with ``--no-time-gate`` goes to
  a column suffixed ``(no time gate)``.
* **Table 3** (``caltech``): TPR per clip (columns 1-4 = cordova1, cordova2, washington1,
  washington2) and ``Ave.``, the mean of the clip TPRs (as the paper's averages are); row = method.
* **Table 4** (``kitti``): BEV ``F_max``, ``Prec.``, ``Rec.``, ``FPR`` (and ``AP``, ``FNR``),
  percent; row = method.
* **Fig. 9** (``tusimple`` in mode ``ego`` / ``3lane``, and ``attributes``): accuracy per mode
  and subset (column ``<mode>: <subset>``), lane colour and style accuracy.
* **CULane** (``culane``, not in the paper): F1 at IoU 0.5 per scenario, F1@75 and mF1.

Each cell of the Markdown output carries a source number; the list under each table gives the
command and the prediction file's SHA-256 of that cell. The Parquet output has one row per cell
with the same columns (``command``, ``predictions``, ``predictions_sha256``, ...).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from superlane_tools._version import __version__
from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.parquet import write_table
from superlane_tools.reporting.provenance import Provenance, input_identity
from superlane_tools.reporting.report import latex_table

KINDS = ("tusimple", "attributes", "kitti", "caltech", "culane")
CALTECH_COLUMNS = {"cordova1": "1", "cordova2": "2", "washington1": "3", "washington2": "4"}
TABLE_TITLES = {
    "Table 2": "Table 2. TuSimple accuracy (sc: slope compensation, sq: sequential initial value)",
    "Table 3": "Table 3. Caltech lanes, true positive rate",
    "Table 4": "Table 4. KITTI ego lane, bird's-eye view (%)",
    "Fig. 9": "Fig. 9. Ego-lane / 3-lane accuracy and lane colour / style accuracy (%)",
    "CULane": "CULane F1 (%), not in the paper",
}


@dataclass(frozen=True)
class FileRef:
    """Identity of an input file of an evaluation."""

    path: str
    name: str
    size_bytes: int
    sha256: str


@dataclass(frozen=True)
class EvalRecord:
    """One saved evaluation (see the module docstring).

    Attributes:
        kind: One of :data:`KINDS`.
        row: Row label of the paper table (method, or ``sq``/``no sq`` in Table 2).
        column: Column label (``sc``/``no sc`` in Table 2, a subset in Fig. 9; may be empty).
        metrics: The numbers (rates in ``[0, 1]``), kind-specific keys.
        command: The command line that produced the record.
        predictions: The predictions (file or folder).
        ground_truth: The ground truth (file or folder).
        tool_version: superlane-tools version.
    """

    kind: str
    row: str
    column: str
    metrics: Mapping[str, Any]
    command: str
    predictions: FileRef
    ground_truth: FileRef
    tool_version: str = __version__
    extra: Mapping[str, Any] = field(default_factory=dict)


def file_ref(path: str | os.PathLike[str]) -> FileRef:
    """Return the identity of a file or folder (SHA-256 of its content)."""
    ident = input_identity(path, "sha256")  # the tables' columns are named for SHA-256
    return FileRef(str(path), ident.name, ident.size_bytes, ident.hex_digest)


def save_record(record: EvalRecord, out: str | os.PathLike[str]) -> Path:
    """Write an evaluation record as JSON (atomically).

    Raises:
        OutputError: For an unknown kind.
    """
    if record.kind not in KINDS:
        raise OutputError(f"unknown evaluation kind {record.kind!r}")
    return write_text_atomic(out, json.dumps(asdict(record), indent=2, default=_json) + "\n")


def _json(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def load_record(path: str | os.PathLike[str]) -> EvalRecord:
    """Read an evaluation record written by :func:`save_record`.

    Raises:
        OutputError: If the file is unreadable or not an evaluation record.
    """
    file = Path(path)
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
        return EvalRecord(
            kind=str(data["kind"]),
            row=str(data["row"]),
            column=str(data["column"]),
            metrics=dict(data["metrics"]),
            command=str(data["command"]),
            predictions=FileRef(**data["predictions"]),
            ground_truth=FileRef(**data["ground_truth"]),
            tool_version=str(data.get("tool_version", "")),
            extra=dict(data.get("extra") or {}),
        )
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise OutputError(f"cannot read evaluation record {file}: {err}") from err
    except (KeyError, TypeError) as err:
        raise OutputError(f"{file}: not an evaluation record (slt eval ... --save)") from err


def _cells(record: EvalRecord) -> list[tuple[str, str, str, float, str]]:
    """Return ``(table, row, column, value, metric)`` cells of one record."""
    m = record.metrics
    row = record.row
    if record.kind == "tusimple":
        mode = str(record.extra.get("mode", "all"))
        gate = "" if record.extra.get("time_gate", True) else " (no time gate)"
        if mode == "all":
            col = (record.column or "sc") + gate
            return [("Table 2", row, col, float(m["accuracy"]), "accuracy")]
        col = (f"{mode}: {record.column}" if record.column else mode) + gate
        return [("Fig. 9", row, col, float(m["accuracy"]), "accuracy")]
    if record.kind == "attributes":
        prefix = f"{record.column} " if record.column else ""
        return [
            ("Fig. 9", row, f"{prefix}colour", _num(m["color_accuracy"]), "color_accuracy"),
            ("Fig. 9", row, f"{prefix}style", _num(m["style_accuracy"]), "style_accuracy"),
        ]
    if record.kind == "kitti":
        names = (
            ("F_max", "max_f"),
            ("Prec.", "precision"),
            ("Rec.", "recall"),
            ("FPR", "fpr"),
            ("AP", "average_precision"),
            ("FNR", "fnr"),
        )
        return [("Table 4", row, col, float(m[key]), key) for col, key in names]
    if record.kind == "caltech":
        clips = m["clips"]
        cells = [
            ("Table 3", row, CALTECH_COLUMNS.get(name, name), float(c["tpr"]), "tpr")
            for name, c in clips.items()
        ]
        if clips:
            mean = sum(float(c["tpr"]) for c in clips.values()) / len(clips)
            cells.append(("Table 3", row, "Ave.", mean, "mean clip tpr"))
        return cells
    if record.kind == "culane":
        cells = [
            ("CULane", row, name, float(s["f1_50"]), "f1@0.5") for name, s in m["sets"].items()
        ]
        overall = m["sets"].get("all") or next(iter(m["sets"].values()))
        cells.append(("CULane", row, "F1@75", float(overall["f1_75"]), "f1@0.75"))
        cells.append(("CULane", row, "mF1", float(overall["mf1"]), "mF1"))
        return cells
    raise OutputError(f"unknown evaluation kind {record.kind!r}")


def _num(value: Any) -> float:
    return float(value) if value is not None else math.nan


def paper_cells(records: Sequence[EvalRecord], sources: Sequence[str]) -> pd.DataFrame:
    """Return one row per table cell: where it goes, its value, and where it came from.

    Raises:
        OutputError: If two records fill the same cell, or there is no record.
    """
    if not records:
        raise OutputError("no evaluation records given")
    rows: list[dict[str, Any]] = []
    seen: dict[tuple[str, str, str], str] = {}
    for record, source in zip(records, sources, strict=True):
        for table, row, column, value, metric in _cells(record):
            key = (table, row, column)
            if key in seen:
                raise OutputError(
                    f"{source} and {seen[key]} both fill {table} row {row!r} column {column!r}"
                )
            seen[key] = source
            rows.append(
                {
                    "table": table,
                    "row": row,
                    "column": column,
                    "value": value,
                    "metric": metric,
                    "kind": record.kind,
                    "result_file": source,
                    "command": record.command,
                    "predictions": record.predictions.path,
                    "predictions_sha256": record.predictions.sha256,
                    "ground_truth": record.ground_truth.path,
                    "ground_truth_sha256": record.ground_truth.sha256,
                    "tool_version": record.tool_version,
                }
            )
    return pd.DataFrame(rows)


def _format(table: str, value: float) -> str:
    if not math.isfinite(value):
        return "-"
    if table == "Table 3":
        return f"{value:.3f}"
    if table == "Table 4":
        return f"{100 * value:.1f}"
    return f"{100 * value:.2f}%"


def _order(table: str, rows: list[str], cols: list[str]) -> tuple[list[str], list[str]]:
    if table == "Table 2":
        rows = sorted(rows, key=lambda r: (r != "no sq", r))
        cols = sorted(cols, key=lambda c: ("time gate" in c, not c.startswith("no sc"), c))
    elif table == "Table 3":
        cols = sorted(cols, key=lambda c: (c == "Ave.", c))
    elif table == "Fig. 9":
        rank = {"ego": 0, "3lan": 1}
        cols = sorted(cols, key=lambda c: (rank.get(c[:4].rstrip(":"), 2), c))
    return rows, cols


def _layout(part: pd.DataFrame, table: str) -> tuple[list[str], list[str], dict[str, int]]:
    """Return the ordered rows and columns and the source numbers in reading order."""
    rows, cols = _order(
        table, list(dict.fromkeys(part["row"])), list(dict.fromkeys(part["column"]))
    )
    numbers: dict[str, int] = {}
    for r in rows:
        for c in cols:
            hit = part[(part["row"] == r) & (part["column"] == c)]
            if not hit.empty:
                numbers.setdefault(str(hit["result_file"].iloc[0]), len(numbers) + 1)
    return rows, cols, numbers


def _grid(cells: pd.DataFrame, table: str, with_refs: bool) -> pd.DataFrame:
    part = cells[cells["table"] == table]
    rows, cols, numbers = _layout(part, table)
    out: list[dict[str, str]] = []
    for r in rows:
        line = {"": r}
        for c in cols:
            hit = part[(part["row"] == r) & (part["column"] == c)]
            if hit.empty:
                line[c] = ""
                continue
            text = _format(table, float(hit["value"].iloc[0]))
            ref = numbers[str(hit["result_file"].iloc[0])]
            line[c] = f"{text} [{ref}]" if with_refs else text
        out.append(line)
    return pd.DataFrame(out)


def _tables(cells: pd.DataFrame) -> list[str]:
    return [t for t in TABLE_TITLES if t in set(cells["table"])]


def _source_lines(part: pd.DataFrame, table: str, prefix: str) -> list[str]:
    lines = []
    for src, k in _layout(part, table)[2].items():
        rec = part[part["result_file"] == src].iloc[0]
        lines.append(
            f"{prefix}[{k}] `{rec['command']}` -- predictions `{rec['predictions']}` "
            f"(sha256 {str(rec['predictions_sha256'])[:16]}), ground truth "
            f"`{rec['ground_truth']}` (sha256 {str(rec['ground_truth_sha256'])[:16]}), "
            f"record `{src}`"
        )
    return lines


def paper_markdown(cells: pd.DataFrame) -> str:
    """Return the tables in Markdown, each followed by the sources ``[k]`` of its cells."""
    parts: list[str] = []
    for table in _tables(cells):
        grid = _grid(cells, table, with_refs=True)
        cols = [str(c) for c in grid.columns]
        lines = [
            f"### {TABLE_TITLES[table]}",
            "",
            "| " + " | ".join(cols) + " |",
            "|" + "|".join("---" for _ in cols) + "|",
        ]
        lines += ["| " + " | ".join(str(v) for v in row) + " |" for row in grid.to_numpy()]
        lines += ["", "Sources:", ""]
        lines += _source_lines(cells[cells["table"] == table], table, "* ")
        parts.append("\n".join(lines) + "\n")
    return "\n".join(parts)


def paper_latex(cells: pd.DataFrame) -> str:
    """Return the tables as LaTeX ``tabular`` blocks, with their sources as comments."""
    parts: list[str] = []
    for table in _tables(cells):
        parts.append(f"% {TABLE_TITLES[table]}")
        grid = _grid(cells, table, with_refs=True)
        for col in grid.columns[1:]:
            grid[col] = grid[col].str.replace(r" \[(\d+)\]$", r"$^{\1}$", regex=True)
        parts.extend(_source_lines(cells[cells["table"] == table], table, "% "))
        parts.append(latex_table(grid))
    return "\n".join(parts)


def write_paper_tables(
    cells: pd.DataFrame, out: str | os.PathLike[str], sources: Sequence[str], command: str = ""
) -> Path:
    """Write the paper tables as ``.md``, ``.tex`` or ``.parquet`` (one row per cell).

    Raises:
        OutputError: For another suffix.
    """
    path = Path(out)
    suffix = path.suffix.lower()
    if suffix == ".md":
        return write_text_atomic(path, paper_markdown(cells))
    if suffix == ".tex":
        return write_text_atomic(path, paper_latex(cells))
    if suffix == ".parquet":
        provenance = Provenance(command=command, inputs=tuple(input_identity(s) for s in sources))
        return write_table(cells, path, provenance)
    raise OutputError(f"{path}: table format must be one of .md, .tex, .parquet")
