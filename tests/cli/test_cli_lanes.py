"""`slt lanes fit` and `slt lanes export-tusimple` on class-id PNGs written to a temp folder."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from superlane_tools.camera import load_camera
from superlane_tools.cli.app import app
from superlane_tools.reporting import read_provenance

CLASSES = "road: [1]\nlane_marking: [2]\ndividing_yellow_solid: [3]\nvehicle: [7]\n"


@pytest.fixture
def seg_dir(tmp_path: Path, renderer) -> Path:
    cam = load_camera("sim_default")
    root = tmp_path / "seg"
    for k, a1 in enumerate([0.0, 0.01, 0.02]):
        lane_uv, road_uv = renderer(cam, [-1.8, 1.9, 5.6], a1, 0.0005, 0.0)
        mask = np.zeros((cam.height, cam.width), np.uint8)
        r = road_uv.astype(int)
        mask[r[:, 1], r[:, 0]] = 1
        lane = lane_uv.astype(int)
        left = lane[:, 0] < 300
        mask[lane[:, 1], lane[:, 0]] = np.where(left, 3, 2)
        sub = root / "clip" if k else root
        sub.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(sub / f"{k:04d}.png"), mask)
    (root / "classes.yaml").write_text(CLASSES, encoding="utf-8")
    return root


def test_fit_and_export(seg_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "lanes.parquet"
    runner = CliRunner()
    res = runner.invoke(
        app,
        [
            "lanes",
            "fit",
            str(seg_dir),
            "--camera",
            "sim_default",
            "--out",
            str(out),
            "--sequential",
        ],
    )
    assert res.exit_code == 0, res.output
    table = pq.read_table(out).to_pylist()
    assert [row["name"] for row in table] == ["0000.png", "clip/0001.png", "clip/0002.png"]
    for row, a1 in zip(table, [0.0, 0.01, 0.02], strict=True):
        assert abs(row["a1"] - a1) < 0.003
        assert len(row["offsets"]) == 3
        assert row["reason"] == ""
        assert abs(row["lane_width"] - 3.7) < 0.1
    assert read_provenance(out)["config"]["fit_params"]["kappa"] == 2.0
    pred = tmp_path / "pred.json"
    res = runner.invoke(
        app,
        [
            "lanes",
            "export-tusimple",
            str(out),
            "--camera",
            "sim_default",
            "--h-samples",
            "160:720:10",
            "--out",
            str(pred),
        ],
    )
    assert res.exit_code == 0, res.output
    records = [json.loads(line) for line in pred.read_text().splitlines()]
    assert records[1]["raw_file"] == "clip/0001.jpg"
    assert records[0]["h_samples"] == list(range(160, 720, 10))
    assert all(len(lane) == 56 for rec in records for lane in rec["lanes"])
    assert all(rec["run_time"] > 0 for rec in records)
    # Lanes start and end where their pixels do: above the horizon nothing is exported.
    assert all(lane[0] == -2 for rec in records for lane in rec["lanes"])


def test_partial_when_a_png_is_unreadable(seg_dir: Path, tmp_path: Path) -> None:
    (seg_dir / "broken.png").write_bytes(b"not a png")
    res = CliRunner().invoke(
        app,
        [
            "lanes",
            "fit",
            str(seg_dir),
            "--camera",
            "sim_default",
            "--out",
            str(tmp_path / "l.parquet"),
        ],
    )
    assert res.exit_code == 3
    assert "broken.png" in res.output
    assert pq.read_table(tmp_path / "l.parquet").num_rows == 3


@pytest.mark.parametrize(
    ("setup", "code"),
    [("empty", 1), ("no-classes", 2), ("bad-camera", 2), ("bad-classes", 2)],
)
def test_bad_input_is_one_line(tmp_path: Path, seg_dir: Path, setup: str, code: int) -> None:
    target = seg_dir
    camera = "sim_default"
    if setup == "empty":
        target = tmp_path / "empty"
        target.mkdir()
        (target / "classes.yaml").write_text(CLASSES)
    elif setup == "no-classes":
        (seg_dir / "classes.yaml").unlink()
    elif setup == "bad-camera":
        camera = "no_such_profile"
    else:
        (seg_dir / "classes.yaml").write_text("road: [1]\n")
    res = CliRunner().invoke(
        app,
        ["lanes", "fit", str(target), "--camera", camera, "--out", str(tmp_path / "x.pq")],
    )
    assert res.exit_code == code, res.output
    assert "Traceback" not in res.output
    if setup == "bad-camera":  # a bad option value: click's usage error, checked before any work
        assert res.output.count("Invalid value for '--camera'") == 1
    else:
        assert res.output.count("slt: error:") == 1


def test_export_rejects_bad_h_samples_and_files(tmp_path: Path) -> None:
    runner = CliRunner()
    not_parquet = tmp_path / "x.parquet"
    not_parquet.write_text("nope")
    res = runner.invoke(
        app,
        [
            "lanes",
            "export-tusimple",
            str(not_parquet),
            "--camera",
            "sim_default",
            "--out",
            str(tmp_path / "p.json"),
        ],
    )
    assert res.exit_code == 1
    assert "slt: error:" in res.output
    res = runner.invoke(
        app,
        [
            "lanes",
            "export-tusimple",
            str(not_parquet),
            "--camera",
            "sim_default",
            "--h-samples",
            "720:160:10",
            "--out",
            str(tmp_path / "p.json"),
        ],
    )
    assert res.exit_code == 2
