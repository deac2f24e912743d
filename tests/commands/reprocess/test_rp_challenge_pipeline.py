"""The challenge-set pipeline end to end on one tiny drive (real subprocesses and files)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pandas as pd
import pytest

pytestmark = pytest.mark.slow  # minutes of subprocesses; run with -m slow

SCRIPT = Path(__file__).resolve().parents[3] / "pipelines" / "reprocess_challenge.py"


def test_challenge_pipeline_writes_tables_and_commands(tmp_path: Path) -> None:
    module = runpy.run_path(str(SCRIPT))
    report = tmp_path / "report"
    argv = ["--work", str(tmp_path / "work"), "--report", str(report), "--duration", "2"]
    argv += ["--width", "320", "--height", "180", "--scenarios", "hills"]
    assert module["main"](argv) == 0, sys.stderr
    for name in ("availability.md", "availability.tex", "curvature.md", "curvature_oracle.md"):
        assert (report / name).stat().st_size > 0, name
    commands = (report / "commands.txt").read_text(encoding="utf-8").splitlines()
    assert commands[1].startswith("slt simulate -s hills")
    assert sum(line.startswith("slt reprocess") for line in commands) == 3
    assert commands[-1].startswith("# total")
    summary = pd.read_parquet(tmp_path / "work" / "oracle" / "hills" / "curvature_summary.parquet")
    assert "super_path" in set(summary["source"])
    assert "hills" in (report / "availability.md").read_text(encoding="utf-8")
