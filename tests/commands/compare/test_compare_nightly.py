"""`pipelines/nightly.py --baseline`: tonight's root compared with a baseline, frames mined."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType
from typing import Any

import pandas as pd
import pytest

SCRIPT = Path(__file__).resolve().parents[3] / "pipelines" / "nightly.py"


@pytest.fixture(scope="module")
def nightly() -> ModuleType:
    spec = importlib.util.spec_from_file_location("slt_nightly_baseline", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _config(path: Path, labels: Path) -> Path:
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
    good = _config(tmp_path / "good.yaml", labels)
    assert nightly.main([*common, "--out", str(baseline), "--config", str(good)]) == 0
    tonight = tmp_path / "tonight"
    blind = _config(tmp_path / "blind.yaml", oracle_runs.blind.parent.parent / "blind_labels")
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
    assert code == 4, captured
    assert "nightly: regression: availability_frames.super" in captured.err
    summary = tonight / "summary"
    report = (summary / "report.md").read_text(encoding="utf-8")
    assert f"## Comparison with the baseline {baseline}" in report
    assert "## Frames worth labelling" in report
    assert (summary / "compare" / "compare.md").is_file()
    mined = pd.read_parquet(summary / "mined" / "manifest.parquet")
    assert len(mined) == 3
    assert nightly.main([*args[:-4], "--fail-on-regression", "nope"]) == 2
