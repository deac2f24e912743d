"""Whole-run atomicity of ``slt reprocess``: staging, manifest, refusal of incomplete runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from superlane_tools.reporting import OutputError
from superlane_tools.reporting.run_folder import (
    RUN_MANIFEST,
    require_complete_run,
    staged_run,
)


def _fill(folder: Path, tag: str) -> None:
    (folder / "frames.parquet").write_text(tag)
    (folder / "plots").mkdir()
    (folder / "plots" / "a.png").write_text(tag * 3)


def _failing_run(out: Path) -> None:
    with staged_run(out) as stage:
        _fill(stage, "new")
        raise RuntimeError("the run failed")


def test_a_run_is_published_whole_and_replaces_the_previous_one(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with staged_run(out) as stage:
        _fill(stage, "old")
        assert not out.exists()  # nothing visible before the run completes
    require_complete_run(out)
    with pytest.raises(RuntimeError, match="failed"):
        _failing_run(out)
    assert (out / "frames.parquet").read_text() == "old"  # the old run, untouched
    with staged_run(out) as stage:
        _fill(stage, "new")
    assert (out / "frames.parquet").read_text() == "new"
    require_complete_run(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no staging left


def test_incomplete_and_foreign_folders(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with staged_run(out) as stage:
        _fill(stage, "x")
    (out / "plots" / "a.png").write_text("changed")
    with pytest.raises(OutputError, match="changed size"):
        require_complete_run(out)
    (out / RUN_MANIFEST).unlink()
    with pytest.raises(OutputError, match="not a complete reprocess run"):
        require_complete_run(out)
    with pytest.raises(OutputError, match="not empty and not a complete slt run"), staged_run(out):
        pass  # a folder of other files is never replaced
    afile = tmp_path / "file"
    afile.write_text("x")
    with pytest.raises(OutputError, match="not a folder"), staged_run(afile):
        pass


def test_leftovers_of_killed_runs_are_removed(tmp_path: Path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    pid = int(dead.stdout)
    stale = tmp_path / f".run.slt-staging.{pid}.abc123"
    stale.mkdir()
    (stale / "frames.parquet").write_text("half")
    alive = tmp_path / f".run.slt-staging.{os.getppid()}.def456"
    alive.mkdir()  # a run still in progress (its process lives) is left alone
    with staged_run(tmp_path / "run") as stage:
        _fill(stage, "x")
    assert not stale.exists()
    assert alive.exists()


@pytest.mark.realdata
def test_tables_refuse_a_run_without_manifest(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from superlane_tools.cli.app import app

    run = tmp_path / "killed"
    run.mkdir()
    import pandas as pd

    pd.DataFrame({"method": ["super"]}).to_parquet(run / "availability_sequences.parquet")
    res = CliRunner().invoke(app, ["tables", "availability", str(run)])
    assert res.exit_code == 1
    assert "not a complete reprocess run folder" in res.output
