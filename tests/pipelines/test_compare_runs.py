"""`pipelines/compare_runs.py`: two runs of one drive are identical; a changed cell is not."""

from __future__ import annotations

import re
import runpy
import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.simulation.drive import simulate_drive

SCRIPT = Path(__file__).resolve().parents[2] / "pipelines" / "compare_runs.py"


def test_reprocess_is_reproducible_and_a_changed_cell_is_found(tmp_path: Path) -> None:
    compare = runpy.run_path(str(SCRIPT))["compare_runs"]
    rec = tmp_path / "d.mcap"
    simulate_drive("highway_curves", 1.0, 3, "mcap", 320, 180, False, rec)
    cfg = ReprocessConfig().with_overrides({"output.plots": False})
    reprocess(rec, tmp_path / "a", cfg)
    reprocess(rec, tmp_path / "b", cfg)
    compared, diffs = compare(tmp_path / "a", tmp_path / "b")
    assert diffs == []
    assert {"curvature.parquet", "lanes.parquet", "annotations.mcap", "report.md"} <= set(compared)

    changed = tmp_path / "c"
    shutil.copytree(tmp_path / "b", changed)
    table = pq.read_table(changed / "curvature.parquet")
    column = table["super_curvature"].to_pylist()
    column[3] = (column[3] or 0.0) + 1e-9
    index = table.column_names.index("super_curvature")
    table = table.set_column(index, "super_curvature", pa.array(column, pa.float64()))
    pq.write_table(table, changed / "curvature.parquet")
    _, diffs = compare(tmp_path / "a", changed)
    assert len(diffs) == 1
    assert diffs[0].startswith("curvature.parquet.super_curvature: 1 cells differ, first row 3")

    # The self-check's measured wall time is masked in report.md; any other change is not.
    timed = tmp_path / "t"
    shutil.copytree(tmp_path / "b", timed)
    report = (timed / "report.md").read_text(encoding="utf-8")
    retimed = re.sub(r"(self-check on \d+ frames \()\d+(?:\.\d+)? s\)", r"\g<1>99.9 s)", report)
    assert retimed != report
    recosted = re.sub(r"(self-check cost: )\d+(?:\.\d+)? s CPU", r"\g<1>99.99 s CPU", retimed)
    assert recosted != retimed
    retimed = recosted
    (timed / "report.md").write_text(retimed, encoding="utf-8")
    assert compare(tmp_path / "a", timed)[1] == []
    (timed / "report.md").write_text(report.replace("Run", "Ran", 1), encoding="utf-8")
    assert any(d.startswith("report.md differs") for d in compare(tmp_path / "a", timed)[1])
