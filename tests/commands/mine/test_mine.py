"""``slt mine`` on real reprocess runs (see tests/commands/conftest.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.evaluation.culane import read_lines_file
from superlane_tools.evaluation.tusimple import load_jsonl
from superlane_tools.reporting.layout import MINE_MANIFEST_TABLE, checked_table

runner = CliRunner()


def _mine_span(oracle_runs: Any, tmp_path: Path, criteria: str, frames: int, gap: str) -> Path:
    """Compare the base run with the blind one, then mine the base run with the spans."""
    cmp = runner.invoke(
        app,
        [
            "compare",
            str(oracle_runs.base),
            str(oracle_runs.blind),
            "-o",
            str(tmp_path / "cmp"),
            "--no-plots",
        ],
    )
    assert cmp.exit_code == 0, cmp.output
    out = tmp_path / "set"
    mined = runner.invoke(
        app,
        [
            "mine",
            str(oracle_runs.base),
            "-o",
            str(out),
            "--criteria",
            criteria,
            "--compare",
            str(tmp_path / "cmp"),
            "--recordings",
            str(oracle_runs.recording.parent),
            "--max-frames",
            str(frames),
            "--min-gap-s",
            gap,
        ],
    )
    assert mined.exit_code == 0, mined.output
    return out


def test_mining_picks_the_frames_where_two_runs_disagree(oracle_runs: Any, tmp_path: Path) -> None:
    out = _mine_span(oracle_runs, tmp_path, "span", 3, "0.3")
    manifest = pd.read_parquet(out / "manifest.parquet")
    assert len(manifest) == 3
    checked_table(MINE_MANIFEST_TABLE, manifest)  # the declared schema
    blind = oracle_runs.blind_frames
    assert manifest["frame_index"].between(blind.start - 3, blind.stop + 3).all(), manifest
    assert (np.diff(manifest["log_time_ns"]) >= 0.3e9).all()  # spread, no neighbours
    assert set(manifest["reasons"]) == {"span"}
    for image in manifest["image"]:
        assert (out / image).is_file()
        lines = read_lines_file(out / image.replace(".jpg", ".lines.txt"))
        assert len(lines) >= 2  # the base run's fit: pre-annotations of the ego lines at least


def test_a_mined_set_is_what_slt_train_reads(oracle_runs: Any, tmp_path: Path) -> None:
    from superlane_tools.training.datasets import DatasetSpec, load_set

    out = _mine_span(oracle_runs, tmp_path, "span,disagree", 4, "0.2")
    records = load_jsonl(out / "labels.json")
    assert len(records) == len(pd.read_parquet(out / "manifest.parquet")) == 4
    loaded = load_set(DatasetSpec("tusimple", out, split="all"), "segmentation", (160, 96))
    assert loaded.images.shape[0] == 4
    assert loaded.codes is not None
    assert (loaded.codes > 0).any()  # the TuSimple lines were drawn as marking labels


def test_mining_without_the_recording_is_partial(oracle_runs: Any, tmp_path: Path) -> None:
    mined = runner.invoke(
        app,
        [
            "mine",
            str(oracle_runs.blind),
            "-o",
            str(tmp_path),
            "--criteria",
            "availability_drop",
            "--max-frames",
            "2",
        ],
    )
    assert mined.exit_code == 3, mined.output
    assert "slt: skipped: frames without their recording" in mined.output
    bad = runner.invoke(app, ["mine", str(oracle_runs.blind), "--criteria", "nope"])
    assert bad.exit_code == 2
