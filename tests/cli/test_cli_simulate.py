"""`slt simulate` through Typer's runner: list, drive, dataset, one-line errors."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.reporting import read_provenance
from superlane_tools.simulation.scenarios import SCENARIOS

runner = CliRunner()


def test_list_names_every_scenario() -> None:
    result = runner.invoke(app, ["simulate", "--list"])
    assert result.exit_code == 0
    lines = result.output.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == list(SCENARIOS)


def test_drive_command_writes_recording_and_truth(tmp_path: Path) -> None:
    out = tmp_path / "drive.mcap"
    result = runner.invoke(
        app,
        [
            "simulate",
            "--scenario",
            "urban",
            "--duration",
            "0.4",
            "--width",
            "320",
            "--height",
            "180",
            "--seed",
            "9",
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    assert out.is_file()
    assert (tmp_path / "drive.gt.parquet").is_file()
    assert len(pd.read_parquet(tmp_path / "drive.gt.parquet")) == 6


def test_errors_are_one_line_with_exit_2(tmp_path: Path) -> None:
    cases = [
        ["simulate", "--scenario", "moon", "--out", str(tmp_path / "a.mcap")],
        ["simulate", "--scenario", "urban", "--width", "8", "--out", str(tmp_path / "a.mcap")],
        ["simulate", "--scenario", "urban", "--format", "avi", "--out", str(tmp_path / "a")],
        ["simulate", "--scenario", "urban", "--duration", "0", "--out", str(tmp_path / "a.mcap")],
        ["simulate", "--scenario", "urban", "--rtk-mode", "magic", "--out", str(tmp_path / "b")],
        ["simulate", "--scenario", "urban"],
        ["simulate", "dataset", "--out", str(tmp_path / "ds"), "--frames", "0"],
        [
            "simulate",
            "dataset",
            "--out",
            str(tmp_path / "ds"),
            "--frames",
            "1",
            "--scenarios",
            "moon",
        ],
    ]
    for argv in cases:
        result = runner.invoke(app, argv)
        assert result.exit_code == 2, (argv, result.output)
        assert "Traceback" not in result.output
        assert len(result.output.strip().splitlines()) == 1, result.output
    assert not list(tmp_path.glob("a*"))


def test_dataset_command_writes_images_masks_and_index(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    result = runner.invoke(
        app,
        [
            "simulate",
            "dataset",
            "--out",
            str(out),
            "--frames",
            "3",
            "--scenarios",
            "urban,night",
            "--width",
            "320",
            "--height",
            "180",
            "--seed",
            "5",
        ],
    )
    assert result.exit_code == 0, result.output
    index = pd.read_parquet(out / "index.parquet")
    assert index["scenario"].tolist() == ["urban", "night", "urban"]
    for col in ("image", "labels", "corridor"):
        assert all((out / p).is_file() for p in index[col])
    assert index["fx"].nunique() == 3  # randomised cameras
    assert read_provenance(out / "index.parquet")["config"]["seed"] == 5
