"""Caltech lanes TPR: Bezier sampling, Aly's spline matching, labels.ccvl reading, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io as sio
from typer.testing import CliRunner

from superlane_tools.camera import load_camera
from superlane_tools.cli.app import app
from superlane_tools.evaluation.caltech import (
    bezier_points,
    curves_match,
    evaluate_clip,
    frame_matches,
    polyline_points,
    read_ccvl,
    score_frames,
)
from superlane_tools.evaluation.culane import format_lines
from superlane_tools.evaluation.errors import EvaluationError

LEFT = np.array([[100.0, 470.0], [150.0, 400.0], [200.0, 330.0], [250.0, 260.0]])
RIGHT = np.array([[560.0, 470.0], [500.0, 400.0], [440.0, 330.0], [380.0, 260.0]])


def test_bezier_points_end_at_the_control_polygon() -> None:
    pts = bezier_points(LEFT)
    assert pts.shape == (101, 2)
    assert np.allclose(pts[0], LEFT[0])
    assert np.allclose(pts[-1], LEFT[-1])
    assert np.allclose(pts[50], LEFT.mean(axis=0))  # collinear, evenly spaced controls
    line = polyline_points(np.array([[0.0, 0.0], [0.0, 10.0], [0.0, 30.0]]), n=4)
    assert np.allclose(line[:, 1], [0.0, 10.0, 20.0, 30.0])


def test_matching_thresholds() -> None:
    truth = bezier_points(LEFT)
    assert curves_match(truth, truth)
    assert curves_match(truth + np.array([12.0, 0.0]), truth)  # mean and median ~ 10 px
    assert not curves_match(truth + np.array([40.0, 0.0]), truth)


def test_perfect_empty_shifted_duplicate_frames() -> None:
    truths = [LEFT, RIGHT]
    perfect = [bezier_points(LEFT), bezier_points(RIGHT)]
    assert frame_matches(perfect, truths) == (2, 0, 0)
    assert frame_matches([], truths) == (0, 0, 0)
    assert frame_matches([bezier_points(LEFT) + np.array([60.0, 0.0])], truths) == (0, 1, 0)
    # Aly's script counts each correct detection, so a duplicate is "correct" twice
    assert frame_matches(
        [bezier_points(LEFT), bezier_points(LEFT) + np.array([3.0, 0.0])], truths
    ) == (
        2,
        0,
        1,
    )
    score = score_frames("c", [(perfect, truths), ([], truths), (perfect[:1], truths)])
    assert (score.n_truth, score.correct, score.false) == (6, 3, 0)
    assert score.tpr == pytest.approx(0.5)
    assert score.fp_per_frame == 0.0


def _write_clip(root: Path, clip: str) -> None:
    frames = [
        {
            "frame": "f00000.png",
            "labels": [
                {"type": "spline", "subtype": "sw", "points": LEFT},
                {"type": "spline", "subtype": "bw", "points": RIGHT},
                {"type": "polygon", "subtype": "x", "points": np.zeros((3, 2))},
            ],
        },
        {"frame": "f00001.png", "labels": [{"type": "spline", "subtype": "sw", "points": LEFT}]},
    ]
    (root / clip).mkdir(parents=True)
    sio.savemat(str(root / clip / "labels.ccvl"), {"ld": {"frames": frames}}, appendmat=False)


def test_ccvl_reader_and_clip_score(tmp_path: Path) -> None:
    _write_clip(tmp_path / "data", "cordova1")
    frames = read_ccvl(tmp_path / "data" / "cordova1" / "labels.ccvl")
    assert [f for f, _ in frames] == ["f00000.png", "f00001.png"]
    assert [len(s) for _, s in frames] == [2, 1]  # the polygon is not a lane
    pred = tmp_path / "pred" / "cordova1"
    pred.mkdir(parents=True)
    (pred / "f00000.lines.txt").write_text(format_lines([bezier_points(LEFT)[::10]]))
    score, missing = evaluate_clip(pred, tmp_path / "data" / "cordova1" / "labels.ccvl", "c1")
    assert missing == ["f00001.png"]
    assert score.tpr == pytest.approx(1 / 3)
    bad = tmp_path / "bad.ccvl"
    bad.write_bytes(b"not a mat file")
    with pytest.raises(EvaluationError):
        read_ccvl(bad)


def test_cli_caltech(tmp_path: Path) -> None:
    data, pred = tmp_path / "data", tmp_path / "pred"
    for clip in ("cordova1", "washington2"):
        _write_clip(data, clip)
        (pred / clip).mkdir(parents=True)
        for name, lanes in (("f00000", [LEFT, RIGHT]), ("f00001", [LEFT])):
            text = format_lines([bezier_points(c)[::5] for c in lanes])
            (pred / clip / f"{name}.lines.txt").write_text(text)
    rec = tmp_path / "rec.json"
    res = CliRunner().invoke(app, ["eval", "caltech", str(pred), str(data), "--save", str(rec)])
    assert res.exit_code == 0, res.output
    assert "cordova1" in res.stdout
    clips = json.loads(rec.read_text())["metrics"]["clips"]
    assert set(clips) == {"cordova1", "washington2"}
    assert clips["cordova1"]["tpr"] == 1.0
    res = CliRunner().invoke(app, ["eval", "caltech", str(pred), str(tmp_path / "none")])
    assert res.exit_code == 1


def test_caltech_camera_profile() -> None:
    cam = load_camera("caltech")
    assert (cam.width, cam.height) == (640, 480)
    assert cam.extrinsics.pitch_rad == pytest.approx(np.radians(14.0))
    # horizon 344.2161 * tan(14 deg) = 85.8 px above the optical centre; a road point 20 m
    # ahead lies atan(2.1798 / 20) below it, on the centre column
    uv, front = cam.project(np.array([[20.0, 0.0, 0.0]]))
    assert front[0]
    assert uv[0, 0] == pytest.approx(cam.intrinsics.cx)
    angle = np.radians(14.0) - np.arctan(2.1798 / 20.0)
    assert uv[0, 1] == pytest.approx(256.5352 - 344.2161 * np.tan(angle), abs=1e-6)
