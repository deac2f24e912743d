"""TuSimple export rules: line caps, lane count, per-entry rows, run time, vertical curve c."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from superlane_tools.camera import load_camera
from superlane_tools.cli.app import app
from superlane_tools.evaluation import load_jsonl
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.tusimple_export import (
    ExportOptions,
    FittedFrame,
    export_records,
    frame_record,
    rows_by_raw_file,
    select_lines,
)
from superlane_tools.lanes import Lane, lanes_at_rows
from superlane_tools.scene.label_folder import find_masks, natural_key

CAM = load_camera("sim_default")
ROWS = list(range(160, 720, 10))


def _lane(offset: float, n_points: int = 100, colour: str = "white") -> Lane:
    return Lane(offset, 0.0, 0.0, 3.0, 60.0, colour=colour, style="dashed", n_points=n_points)


def test_max_lines_keeps_the_lines_nearest_the_camera_in_order() -> None:
    lanes = [_lane(o) for o in (9.0, 5.5, 1.8, -1.9, -5.6, -9.3, -13.0)]
    assert select_lines(lanes, ExportOptions(max_lines=5)) == [0, 1, 2, 3, 4]
    assert select_lines(lanes, ExportOptions(max_lines=2)) == [2, 3]
    assert select_lines(lanes, ExportOptions(max_lines=None)) == list(range(7))


def test_known_lane_count_keeps_the_best_supported_adjacent_lines() -> None:
    support = [5, 300, 400, 350, 20, 10]
    lanes = [_lane(o, n) for o, n in zip((9.0, 5.5, 1.8, -1.9, -5.6, -9.3), support, strict=True)]
    # 2 lanes = 3 lines: the window 1..3 has the most pixels
    assert select_lines(lanes, ExportOptions(n_lanes=2)) == [1, 2, 3]
    assert select_lines(lanes, ExportOptions(n_lanes=1, max_lines=5)) == [2, 3]
    with pytest.raises(EvaluationError):
        ExportOptions(n_lanes=0)


def test_frame_record_uses_c_run_time_and_attributes() -> None:
    lanes = (_lane(1.8, colour="yellow"), _lane(-1.9))
    flat = FittedFrame("clip/20.png", lanes, b=0.0, c=0.0, fit_time_ms=3.0, seg_time_ms=40.0)
    rec = frame_record(flat, CAM, ROWS, ExportOptions())
    assert rec.raw_file == "clip/20.jpg"
    assert rec.run_time_ms == pytest.approx(43.0)
    assert rec.colors == ("yellow", "white")
    assert rec.styles == ("dashed", "dashed")
    expected = lanes_at_rows(list(lanes), 0.0, CAM, np.asarray(ROWS, float))
    got = np.asarray(rec.lanes)
    ok = np.isfinite(expected) & (expected >= 0) & (expected <= CAM.width - 1)
    assert np.allclose(got[ok], np.round(expected[ok], 1))
    assert np.all(got[~ok] == -2)
    sag = FittedFrame("clip/20.png", lanes, b=0.0, c=4e-4, fit_time_ms=3.0)
    rec_c = frame_record(sag, CAM, ROWS, ExportOptions())
    expected_c = lanes_at_rows(list(lanes), 0.0, CAM, np.asarray(ROWS, float), 4e-4)
    got_c = np.asarray(rec_c.lanes)
    ok_c = np.isfinite(expected_c) & (expected_c >= 0) & (expected_c <= CAM.width - 1)
    assert np.allclose(got_c[ok_c], np.round(expected_c[ok_c], 1))
    assert not np.array_equal(got_c, got)  # the vertical curve moves the far points
    assert rec_c.run_time_ms == pytest.approx(3.0)  # no segmentation time: fit only


def test_rows_come_from_each_task_entry() -> None:
    frames = [
        FittedFrame("a/20.png", (_lane(1.8), _lane(-1.9)), 0.0, 0.0, 1.0),
        FittedFrame("b/20.png", (_lane(1.8), _lane(-1.9)), 0.0, 0.0, 1.0),
    ]
    tasks = {"a/20.jpg": [240.0, 250.0, 260.0], "b/20.jpg": [float(r) for r in ROWS]}
    recs = export_records(frames, [CAM, CAM], ExportOptions(), tasks=tasks)
    assert [len(r.h_samples) for r in recs] == [3, len(ROWS)]
    assert all(len(lane) == len(r.h_samples) for r in recs for lane in r.lanes)
    with pytest.raises(EvaluationError, match="no entry in the task file"):
        export_records(frames, [CAM, CAM], ExportOptions(), tasks={"a/20.jpg": [240.0]})


def test_rows_by_raw_file_from_the_real_labels(realdata: Path) -> None:
    labels = load_jsonl(realdata / "tusimple" / "train_frames" / "labels.json")
    rows = rows_by_raw_file(labels)
    assert len(rows) == 129
    assert rows["images/0000.jpg"][0] == 240.0  # 0313 clips start at row 240, not 160


def test_natural_order_of_masks(tmp_path: Path) -> None:
    for name in ("clip/10.png", "clip/2.png", "clip/1.png", "a.png"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    names = [p.relative_to(tmp_path).as_posix() for p in find_masks(tmp_path)]
    assert names == ["a.png", "clip/1.png", "clip/2.png", "clip/10.png"]
    assert natural_key("x/9.png") < natural_key("x/10.png")


def _mask(offsets: list[float], a1: float) -> np.ndarray:
    lanes = [Lane(o, a1, 0.0, 4.0, 60.0) for o in offsets]
    rows = np.arange(CAM.height, dtype=float)
    cols = lanes_at_rows(lanes, 0.0, CAM, rows)
    mask = np.zeros((CAM.height, CAM.width), np.uint8)
    mask[400:, :] = 1
    for line in cols:
        for v, u in enumerate(line):
            if math.isfinite(u):
                cv2.circle(mask, (round(u), v), 2, 2, -1)
    return mask


def test_sequential_fit_restarts_in_each_clip_and_export_caps_lines(tmp_path: Path) -> None:
    seg = tmp_path / "seg"
    for clip, a1 in (("c1", 0.0), ("c2", 0.02)):
        for k in (1, 2, 10):
            (seg / clip).mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(seg / clip / f"{k}.png"), _mask([5.6, 1.9, -1.8, -5.5], a1))
    (seg / "classes.yaml").write_text("road: [1]\nlane_marking: [2]\n", encoding="utf-8")
    (seg / "segment_times.csv").write_text("name,seg_ms\nc1/1,30.5\n", encoding="utf-8")
    runner = CliRunner()
    outs = {}
    for flag in ("--sequential", "--no-sequential"):
        out = tmp_path / f"l{flag}.parquet"
        args = ["lanes", "fit", str(seg), "--camera", "sim_default", "--out", str(out), flag]
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
        outs[flag] = pq.read_table(out).to_pylist()
    seq, cold = outs["--sequential"], outs["--no-sequential"]
    assert [r["name"] for r in seq] == [
        "c1/1.png",
        "c1/2.png",
        "c1/10.png",
        "c2/1.png",
        "c2/2.png",
        "c2/10.png",
    ]
    # the first frame of each clip starts cold: same fit as without --sequential
    for i in (0, 3):
        assert seq[i]["a1"] == cold[i]["a1"]
        assert seq[i]["offsets"] == cold[i]["offsets"]
    assert seq[0]["seg_time_ms"] == 30.5
    assert math.isnan(seq[1]["seg_time_ms"])
    pred = tmp_path / "pred.json"
    res = runner.invoke(
        app,
        [
            "lanes",
            "export-tusimple",
            str(tmp_path / "l--sequential.parquet"),
            "--camera",
            "sim_default",
            "--out",
            str(pred),
            "--max-lines",
            "2",
        ],
    )
    assert res.exit_code == 0, res.output
    recs = [json.loads(line) for line in pred.read_text().splitlines()]
    assert all(len(r["lanes"]) <= 2 for r in recs)
    assert recs[0]["run_time"] == pytest.approx(30.5 + seq[0]["fit_time_ms"], abs=1e-3)
    assert all(len(r["color"]) == len(r["lanes"]) for r in recs)
    res = runner.invoke(
        app,
        [
            "lanes",
            "export-tusimple",
            str(tmp_path / "l--sequential.parquet"),
            "--camera",
            "sim_default",
            "--out",
            str(pred),
            "--lanes",
            "0",
        ],
    )
    assert res.exit_code == 2
