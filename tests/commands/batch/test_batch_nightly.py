"""`pipelines/nightly.py` on fixtures: new recordings only, state, systemic failure codes."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pandas as pd
import pytest

pytestmark = pytest.mark.slow  # minutes of subprocesses; run with -m slow

SCRIPT = Path(__file__).resolve().parents[3] / "pipelines" / "nightly.py"


@pytest.fixture(scope="module")
def nightly() -> ModuleType:
    spec = importlib.util.spec_from_file_location("slt_nightly", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _age(path: Path, seconds: float) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t))


def test_nightly_processes_only_new_recordings(
    tmp_path: Path,
    nightly: ModuleType,
    make_drives: Callable[..., list[Path]],
    write_drive: Callable[..., Path],
    capsys: pytest.CaptureFixture[str],
) -> None:
    paths = make_drives(3, 1)
    for p in paths:
        _age(p, 3600)
    fresh = write_drive(tmp_path / "recs" / "copying.mcap", seed=9)  # just written: settles
    out = tmp_path / "runs"
    base = [
        "--source",
        str(tmp_path / "recs"),
        "--out",
        str(out),
        "--job",
        "extract",
        "--workers",
        "2",
        "--settle-min",
        "10",
    ]
    code = nightly.main(base)
    assert code == 0, capsys.readouterr()  # one corrupt recording is not a systemic failure
    state = json.loads((out / "nightly_state.json").read_text())
    assert state["last_counts"] == {"ok": 3, "partial": 0, "failed": 1, "skipped": 0}, (
        capsys.readouterr()
    )
    assert (out / "summary" / "report.md").is_file()
    status = pd.read_parquet(out / "batch_status.parquet")
    assert "copying" not in " ".join(status["recording"])

    assert nightly.main(base) == 0
    assert "nothing new" in capsys.readouterr().out

    # the next night: the copy has settled (modelled by no settling delay), still newer than
    # the watermark of the first run
    assert fresh.stat().st_mtime_ns > state["watermark_ns"]
    assert nightly.main([*base, "--settle-min", "0"]) == 0
    state = json.loads((out / "nightly_state.json").read_text())
    assert state["last_counts"] == {"ok": 1, "partial": 0, "failed": 0, "skipped": 0}, (
        capsys.readouterr()
    )
    assert len(pd.read_parquet(out / "batch_status.parquet")) == 5


def test_nightly_systemic_failures(
    tmp_path: Path, nightly: ModuleType, make_drives: Callable[..., list[Path]]
) -> None:
    make_drives(1, 2)
    manifest = tmp_path / "m.yaml"
    manifest.write_text("\n".join(f"- {p}" for p in sorted((tmp_path / "recs").iterdir())))
    out = tmp_path / "runs"
    args = ["--manifest", str(manifest), "--out", str(out), "--job", "extract", "--retries", "0"]
    assert nightly.main(args) == 1  # 2 of 3 failed
    assert not (out / "nightly_state.json").exists()
    (tmp_path / "blocker").write_text("a file where the output root should be")
    bad = [
        "--manifest",
        str(manifest),
        "--out",
        str(tmp_path / "blocker" / "runs"),
        "--job",
        "extract",
    ]
    assert nightly.main(bad) == 1
    assert nightly.main(["--source", str(tmp_path / "nope"), "--out", str(out)]) == 2


def test_nightly_script_runs_as_a_program(tmp_path: Path) -> None:
    (tmp_path / "recs").mkdir()
    result = subprocess.run(
        [
            sys.executable,
            str(SCRIPT),
            "--source",
            str(tmp_path / "recs"),
            "--out",
            str(tmp_path / "runs"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "nothing new" in result.stdout


def _oracle_config(path: Path, labels: Path) -> Path:
    path.write_text(
        "segmentation:\n  backend: oracle\n"
        f"  oracle_labels: {labels}\n"
        "output:\n  plots: false\n  example_frames: 0\nkpi:\n  window_s: 0.25\n",
        encoding="utf-8",
    )
    return path


@pytest.mark.slow  # two batch runs in worker processes
def test_nightly_compares_with_the_baseline_and_mines(
    oracle_runs: Any, nightly: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rec = oracle_runs.recording
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(f"path\n{rec}\n", encoding="utf-8")
    labels = rec.parent / "curves_labels" / "labels"
    common = ["--manifest", str(manifest), "--workers", "1", "--job", "reprocess"]
    baseline = tmp_path / "baseline"
    good = _oracle_config(tmp_path / "good.yaml", labels)
    assert nightly.main([*common, "--out", str(baseline), "--config", str(good)]) == 0
    tonight = tmp_path / "tonight"
    blind = _oracle_config(
        tmp_path / "blind.yaml", oracle_runs.blind.parent.parent / "blind_labels"
    )
    args = [
        *common,
        "--out",
        str(tonight),
        "--config",
        str(blind),
        "--baseline",
        str(baseline),
        "--fail-on-regression",
        "availability_frames.super",
        "--mine",
        "3",
    ]
    code = nightly.main(args)
    captured = capsys.readouterr()
    # One drive is too few for a fleet verdict (slt compare needs 10): the gate cannot decide,
    # and a gate never passes what it could not judge.
    assert code == 3, captured
    undecided = "nightly: gate cannot decide: too few drives (1 matched, a verdict needs 10)"
    assert undecided in captured.err
    summary = tonight / "summary"
    report = (summary / "report.md").read_text(encoding="utf-8")
    assert f"## Comparison with the baseline {baseline}" in report
    assert "## Frames worth labelling" in report
    assert (summary / "compare" / "compare.md").is_file()
    mined = pd.read_parquet(summary / "mined" / "manifest.parquet")
    assert len(mined) == 3
    assert nightly.main([*args[:-4], "--fail-on-regression", "nope"]) == 2
