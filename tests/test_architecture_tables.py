"""Every output table is declared once, in ``reporting/layout/``, and named nowhere else.

Two-sided: the layout package writes each output file name once (and every table's name is a
:class:`~superlane_tools.reporting.layout.TableSpec`), and no string shaped like an output
name (``lanes.parquet``, ``report.md``) appears anywhere else in the package or the pipelines,
whether the layout knows the name or not: a new output file gets its name in the layout first
(benchmarks, which write result files of their own, may not write the layout's names).
Schemas are defined only in the layout too, and the readers' column lists are the specs'.
"""

from __future__ import annotations

import ast
import re
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "superlane_tools"
LAYOUT = PACKAGE / "reporting" / "layout"
"""The one package that names every output file and defines every output schema."""

OUTPUT_NAME = re.compile(r"^[a-z_]+\.(parquet|mcap|md|html|mp4|json|png)$")
"""A string shaped like an output file name (``lanes.parquet``)."""
ELSEWHERE = {
    ("pipelines/real_frames_eval.py", "val_labels.json"),  # a scratch file in its work folder
    ("pipelines/reprocess_challenge.py", "curvature_onnx.md"),  # a page of its report folder
    ("pipelines/release_eval.py", "real.json"),  # real_frames_eval's numbers in its work folder
    ("pipelines/release_eval.py", "real.md"),  # and its report
    ("pipelines/release_eval.py", "sample_drive.mcap"),  # the bundled demo drive: an input
}
"""Output-shaped names outside the layout that are no output of ``slt``: pipelines' own files."""
OTHER_SCHEMAS = {
    "lanes/table.py": {"FIT_COLUMNS"},  # the lane fit's columns, composed by the layout
    "simulation/groundtruth.py": {"GT_SCHEMA"},  # the truth beside a recording (a suffix)
}
"""Schemas defined outside the layout: the lane layer's columns and the simulator's truth."""


def _sources() -> list[Path]:
    return sorted([*PACKAGE.rglob("*.py"), *(ROOT / "pipelines").glob("*.py")])


def _in_layout(path: Path) -> bool:
    return LAYOUT in path.parents


def _output_names(path: Path) -> list[str]:
    """Return every string constant shaped like an output name, once per occurrence."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and OUTPUT_NAME.match(node.value)
    ]


def test_the_layout_names_each_output_file_once() -> None:
    from superlane_tools.reporting.layout import TABLES

    counts = Counter(s for path in LAYOUT.glob("*.py") for s in _output_names(path))
    assert {"lanes.parquet", "curvature_summary.parquet", "annotations.mcap"} <= set(counts)
    assert {"run_manifest.json", "compare_spans.parquet", "batch_status.parquet"} <= set(counts)
    assert {"index.parquet", "manifest.parquet", "curvature_time.png"} <= set(counts)
    twice = sorted(name for name, n in counts.items() if n > 1)
    assert not twice, f"output file names written twice in reporting/layout/: {twice}"
    assert {t.file for t in TABLES} <= set(counts)


def test_no_output_file_name_outside_the_layout() -> None:
    found = {
        (path.relative_to(ROOT).as_posix(), name)
        for path in _sources()
        if not _in_layout(path)
        for name in _output_names(path)
    }
    bad = sorted(found - ELSEWHERE)
    assert not bad, f"output file names outside reporting/layout/ (name them there): {bad}"
    assert found >= ELSEWHERE, f"stale exceptions: {sorted(ELSEWHERE - found)}"


def test_benchmarks_name_slt_outputs_through_the_layout() -> None:
    """Benchmarks keep their own result files, but name what slt writes through the layout."""
    known = {s for path in LAYOUT.glob("*.py") for s in _output_names(path)}
    bad = sorted(
        f"{path.relative_to(ROOT).as_posix()}: {name!r}"
        for path in (ROOT / "benchmarks").rglob("*.py")
        for name in _output_names(path)
        if name in known
    )
    assert not bad, f"slt output file names written in benchmarks/: {bad}"


def _schema_assignments(path: Path) -> set[str]:
    """Return the module-level names assigned a ``pa.schema(...)`` or ``DerivedSchema(...)``."""
    found = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            func = node.value.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in ("schema", "DerivedSchema"):
                found |= {t.id for t in node.targets if isinstance(t, ast.Name)}
    return found


def test_output_schemas_are_defined_only_in_the_layout() -> None:
    schemas = _schema_assignments(LAYOUT / "schemas.py")
    assert {"LANES_SCHEMA", "RTK_TRUTH_SCHEMA", "COMPARE_SPANS_SCHEMA"} <= schemas
    found = {
        path.relative_to(PACKAGE).as_posix(): names
        for path in PACKAGE.rglob("*.py")
        if not _in_layout(path) and (names := _schema_assignments(path))
    }
    assert found == OTHER_SCHEMAS, f"schemas outside reporting/layout/: {found}"


def test_readers_and_writers_take_their_columns_from_the_specs() -> None:
    from superlane_tools.commands.batch.status import COLUMNS as STATUS_COLUMNS
    from superlane_tools.fleet.bootstrap import Delta
    from superlane_tools.fleet.compare import COLUMNS as COMPARE_COLUMNS
    from superlane_tools.fleet.mining import CRITERIA
    from superlane_tools.fleet.runs import OPTIONAL_COLUMNS, REQUIRED_COLUMNS
    from superlane_tools.reporting.layout import (
        BATCH_STATUS_TABLE,
        COMPARE_TABLE,
        MINE_CRITERIA,
        RunLayout,
    )

    assert COMPARE_TABLE.columns == COMPARE_COLUMNS
    assert COMPARE_COLUMNS[-len(Delta._fields) :] == Delta._fields
    assert tuple(STATUS_COLUMNS) == BATCH_STATUS_TABLE.columns
    assert MINE_CRITERIA == CRITERIA
    tables = RunLayout.tables()
    for name, columns in {**REQUIRED_COLUMNS, **OPTIONAL_COLUMNS}.items():
        assert set(columns) <= set(tables[name].columns), name


def test_each_derived_table_is_a_field_of_the_drives_tables() -> None:
    """Reprocess writes ``DerivedTables.<name>`` for every derived spec (matched by the name)."""
    from dataclasses import fields

    from superlane_tools.drive.finalize import DerivedTables
    from superlane_tools.fleet.kpis import DriveTables as KpiTables
    from superlane_tools.reporting.layout import DERIVED_TABLES, RunLayout

    assert set(DERIVED_TABLES) <= {f.name for f in fields(DerivedTables)}
    assert {f.name for f in fields(KpiTables)} <= set(RunLayout.tables())
