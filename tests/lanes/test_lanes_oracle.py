"""The TuSimple oracle pipeline on 30 real train labels reaches LaneEval accuracy >= 0.97."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "pipelines" / "tusimple_oracle.py"


def test_oracle_on_real_train_labels(realdata: Path, tmp_path: Path) -> None:
    out = tmp_path / "oracle.json"
    report = tmp_path / "oracle.md"
    env = {**os.environ, "SLT_REALDATA": str(realdata)}
    subprocess.run(
        [
            sys.executable,
            str(SCRIPT),
            "--limit",
            "30",
            "--step",
            "120",
            "--workers",
            "1",
            "--variants",
            "full",
            "--no-run-time",
            "--json",
            str(out),
            "--report",
            str(report),
        ],
        check=True,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    result = json.loads(out.read_text())
    full = next(iter(result.values()))
    assert full["n_frames"] == 30
    assert full["accuracy"] >= 0.97
    assert full["fp"] < 0.05
    assert full["fn"] < 0.05
    assert "TuSimple geometry oracle" in report.read_text()
