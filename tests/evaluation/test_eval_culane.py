"""CULane F1: .lines.txt format, IoU of 30 px lanes, Hungarian matching, lists, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.evaluation import load_jsonl
from superlane_tools.evaluation.culane import (
    cross_iou,
    evaluate_folder,
    evaluate_frames,
    format_lines,
    frame_counts,
    parse_lines_text,
)
from superlane_tools.evaluation.errors import EvaluationError


def _vertical(x: float, y0: float = 200.0, y1: float = 580.0) -> np.ndarray:
    ys = np.linspace(y1, y0, 20)
    return np.stack([np.full_like(ys, x), ys], axis=1)


def test_lines_format_round_trip_and_errors() -> None:
    lanes = [_vertical(300.0), _vertical(900.5)]
    back = parse_lines_text(format_lines(lanes))
    assert len(back) == 2
    assert np.allclose(back[1], lanes[1])
    assert parse_lines_text("10 20\n\n") == []  # one point is no lane
    with pytest.raises(EvaluationError, match="odd number"):
        parse_lines_text("1 2 3")
    with pytest.raises(EvaluationError, match="numbers"):
        parse_lines_text("1 x")


def test_perfect_empty_and_far() -> None:
    gt = [_vertical(300.0), _vertical(800.0), _vertical(1300.0)]
    assert frame_counts(gt, gt, (0.5, 0.95)) == [(3, 0, 0), (3, 0, 0)]
    assert frame_counts([], gt) == [(0, 0, 3)]
    assert frame_counts(gt, []) == [(0, 3, 0)]
    far = [_vertical(x + 100.0) for x in (300.0, 800.0, 1300.0)]
    assert frame_counts(far, gt) == [(0, 3, 3)]


def test_shifted_lane_iou_is_known() -> None:
    # two 30 px wide vertical bands 10 px apart overlap over 21 of 41 columns (cv2.line with
    # thickness 30 paints 31 columns); the band ends round the same way for both
    a, b = _vertical(500.0), _vertical(510.0)
    iou = cross_iou([a], [b])[0, 0]
    assert iou == pytest.approx(21 / 41, abs=0.01)
    counts = frame_counts([a], [b], (0.5, 0.55))
    assert counts == [(1, 0, 0), (0, 1, 1)]


def test_hungarian_beats_greedy() -> None:
    # prediction 0 overlaps both GT lanes, prediction 1 only GT 0: one-to-one gives 2 TP
    gt = [_vertical(500.0), _vertical(520.0)]
    pred = [_vertical(512.0), _vertical(500.0)]
    assert frame_counts(pred, gt, (0.3,)) == [(2, 0, 0)]


def test_known_confusion_summed_over_frames() -> None:
    gt = [_vertical(300.0), _vertical(800.0), _vertical(1300.0)]
    pred = [_vertical(300.0), _vertical(800.0), _vertical(1000.0)]
    result = evaluate_frames([(pred, gt), (gt, gt)], thresholds=(0.5, 0.75))
    s = result.at(0.5)
    assert (s.tp, s.fp, s.fn) == (5, 1, 1)
    assert s.precision == pytest.approx(5 / 6)
    assert s.f1 == pytest.approx(5 / 6)
    assert result.mf1 == pytest.approx(5 / 6)
    with pytest.raises(EvaluationError):
        result.at(0.9)


def _tusimple_as_lines(realdata: Path, root: Path, shift: float = 0.0) -> list[str]:
    names = []
    for rec in load_jsonl(realdata / "tusimple" / "train_frames" / "labels.json")[:20]:
        lanes = []
        for xs in rec.lanes:
            pts = [(x + shift, y) for x, y in zip(xs, rec.h_samples, strict=True) if x >= 0]
            if len(pts) >= 2:
                lanes.append(np.asarray(pts))
        rel = Path(rec.raw_file).with_suffix(".lines.txt")
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(format_lines(lanes))
        names.append(rec.raw_file)
    return names


def test_real_labels_against_themselves_and_shifted(realdata: Path, tmp_path: Path) -> None:
    gt_root, pred, moved = tmp_path / "gt", tmp_path / "pred", tmp_path / "moved"
    names = _tusimple_as_lines(realdata, gt_root)
    _tusimple_as_lines(realdata, pred)
    _tusimple_as_lines(realdata, moved, shift=60.0)
    run = evaluate_folder(pred, gt_root, size=(1280, 720))
    assert run.results[0].at(0.5).f1 == pytest.approx(1.0)
    assert run.results[0].mf1 == pytest.approx(1.0)
    assert evaluate_folder(moved, gt_root, size=(1280, 720)).results[0].at(0.5).tp == 0
    listing = tmp_path / "test9_tusimple.txt"
    listing.write_text("".join(f"/{n}\n" for n in names[:5]))
    (pred / Path(names[0]).with_suffix(".lines.txt")).unlink()
    run = evaluate_folder(pred, gt_root, [listing], size=(1280, 720))
    assert run.results[0].name == "test9_tusimple"
    assert run.results[0].n_frames == 5
    assert run.missing == (names[0],)
    assert run.results[0].at(0.5).recall < 1.0


def test_cli_culane(tmp_path: Path) -> None:
    gt_root, pred = tmp_path / "gt", tmp_path / "pred"
    for root in (gt_root, pred):
        (root / "d").mkdir(parents=True)
        (root / "d" / "1.lines.txt").write_text(format_lines([_vertical(300.0)]))
    rec = tmp_path / "r.json"
    res = CliRunner().invoke(
        app, ["eval", "culane", str(pred), str(gt_root), "--json", "--save", str(rec)]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout.splitlines()[-1])["all"]["f1_50"] == 1.0
    assert json.loads(rec.read_text())["kind"] == "culane"
    (pred / "d" / "1.lines.txt").unlink()
    res = CliRunner().invoke(app, ["eval", "culane", str(pred), str(gt_root)])
    assert res.exit_code == 3
