"""pipelines/paper_tables_real.sh on a 2-frame fixture built from the real data."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "pipelines" / "paper_tables_real.sh"


@pytest.mark.slow
def test_pipeline_writes_traceable_tables(realdata: Path, tmp_path: Path) -> None:
    data = tmp_path / "data"
    frames = data / "tusimple" / "train_frames"
    (frames / "images").mkdir(parents=True)
    src = realdata / "tusimple" / "train_frames"
    lines = (src / "labels.json").read_text().splitlines()[:2]
    (frames / "labels.json").write_text("\n".join(lines) + "\n")
    for line in lines:
        rel = json.loads(line)["raw_file"]
        shutil.copy(src / rel, frames / rel)
    shutil.copytree(realdata / "kitti_road", data / "kitti_road")
    (data / "README.md").write_text("fixture\n")
    out = tmp_path / "out"
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    res = subprocess.run(
        ["bash", str(SCRIPT), str(data), str(tmp_path / "work"), str(out)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
        timeout=900,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    md = (out / "paper_tables.md").read_text()
    assert "Table 2." in md
    assert "Table 4." in md
    assert "| no sq |" in md
    assert "| SUPER sc |" in md
    assert (out / "paper_tables.parquet").is_file()
    assert (out / "paper_tables_no_time_gate.tex").is_file()
    assert len(list((out / "records").glob("t2_*.json"))) == 4
    rec = json.loads((out / "records" / "t4_sc.json").read_text())
    assert rec["kind"] == "kitti"
    assert 0.0 <= rec["metrics"]["max_f"] <= 1.0
