"""Ego-lane / 3-lane modes and lane colour / style accuracy on TuSimple-format labels."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.evaluation import TuSimpleRecord, evaluate, format_record, load_jsonl
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.lane_modes import (
    attribute_accuracy,
    base_column,
    evaluate_mode,
    select_mode,
)
from superlane_tools.simulation.drive import simulate_drive

ROWS = [float(r) for r in range(300, 720, 20)]


def _line(base: float, slope: float) -> list[float]:
    """x at each row of a straight line through (base, 700) with dx/dy = slope."""
    return [base + slope * (r - 700.0) for r in ROWS]


def _gt(colors: tuple[str, ...] = (), styles: tuple[str, ...] = ()) -> TuSimpleRecord:
    lanes = [_line(-100, -1.2), _line(300, -0.5), _line(900, 0.5), _line(1500, 1.4)]
    return TuSimpleRecord("f.jpg", lanes, ROWS, 0.0, colors, styles)


def test_base_column_and_selection() -> None:
    assert base_column(_line(300, -0.5), ROWS) == pytest.approx(300.0)
    gap = _line(300, -0.5)[:-5] + [-2.0] * 5  # extrapolated over the missing bottom rows

    assert base_column(gap, ROWS) == pytest.approx(300.0)
    assert base_column([-2.0] * len(ROWS), ROWS) != base_column([-2.0] * len(ROWS), ROWS)
    lanes = _gt().lanes
    assert select_mode(lanes, ROWS, "ego", 640.0) == [1, 2]
    assert select_mode(lanes, ROWS, "3lane", 640.0) == [0, 1, 2, 3]
    assert select_mode(lanes[:3], ROWS, "ego", 1000.0) == [2]  # nothing right of 1000 px
    with pytest.raises(EvaluationError):
        select_mode(lanes, ROWS, "wide", 640.0)


def test_ego_mode_ignores_outer_lines() -> None:
    gt = _gt()
    ego_only = TuSimpleRecord("f.jpg", gt.lanes[1:3], [], 0.0)
    assert evaluate_mode([ego_only], [gt], "ego").accuracy == pytest.approx(1.0)
    assert evaluate([ego_only], [gt]).accuracy == pytest.approx(0.5)  # 2 of 4 lines
    shifted = TuSimpleRecord("f.jpg", [[x + 40 for x in gt.lanes[1]], gt.lanes[2]], [], 0.0)
    score = evaluate_mode([shifted], [gt], "ego")
    assert score.accuracy == pytest.approx(0.5)
    assert score.fn == pytest.approx(0.5)
    empty = TuSimpleRecord("f.jpg", [], [], 0.0)
    assert evaluate_mode([empty], [gt], "3lane").fn == pytest.approx(1.0)


def test_attribute_accuracy_known_confusion() -> None:
    gt = _gt(("yellow", "white", "white", "unknown"), ("solid", "dashed", "double", "solid"))
    pred = TuSimpleRecord(
        "f.jpg", gt.lanes[:3], [], 0.0, ("white", "white", "white"), ("solid", "solid", "solid")
    )
    acc = attribute_accuracy([pred], [gt])
    assert acc.n_found == 3
    assert acc.n_color == 3  # found lines with a known colour
    assert acc.color == pytest.approx(2 / 3)
    assert acc.n_style == 3
    assert acc.style == pytest.approx(2 / 3)  # 'double' counts as solid; dashed missed
    assert attribute_accuracy([gt], [gt]).color == pytest.approx(1.0)
    with pytest.raises(EvaluationError, match="no 'color'"):
        attribute_accuracy([pred], [_gt()])


def test_record_round_trip_keeps_attributes(tmp_path: Path) -> None:
    gt = _gt(("yellow", "white", "white", "white"), ("solid",) * 4)
    path = tmp_path / "gt.json"
    path.write_text(format_record(gt) + "\n")
    assert load_jsonl(path)[0].colors == gt.colors
    path.write_text(json.dumps({"raw_file": "a", "lanes": [[1.0]], "h_samples": [1], "color": []}))
    with pytest.raises(EvaluationError, match="'color' has 0 entries"):
        load_jsonl(path)


def test_real_labels_score_perfectly_in_every_mode(realdata: Path) -> None:
    gts = load_jsonl(realdata / "tusimple" / "train_frames" / "labels.json")
    for mode in ("ego", "3lane"):
        assert evaluate_mode(gts, gts, mode).accuracy == pytest.approx(1.0)
    # dropping every outer line: the ego mode still scores 1, the official mode does not
    ego = [
        g._replace(lanes=[g.lanes[i] for i in select_mode(g.lanes, g.h_samples, "ego", 640)])
        for g in gts
    ]
    assert evaluate_mode(ego, gts, "ego").accuracy == pytest.approx(1.0)
    assert evaluate(ego, gts).accuracy < 0.8


def test_simulated_drive_labels_carry_colour_and_style(tmp_path: Path) -> None:
    simulate_drive("highway_straight", 0.4, 5, "mcap", 640, 360, False, tmp_path / "d.mcap")
    labels = tmp_path / "d.tusimple.json"
    gts = load_jsonl(labels)
    assert gts
    assert all(len(g.colors) == len(g.lanes) == len(g.styles) for g in gts)
    assert {c for g in gts for c in g.colors} <= {"white", "yellow"}
    assert attribute_accuracy(gts, gts).color == pytest.approx(1.0)
    flipped = [
        g._replace(colors=tuple("white" if c == "yellow" else "yellow" for c in g.colors))
        for g in gts
    ]
    acc = attribute_accuracy(flipped, gts)
    assert acc.color == pytest.approx(0.0)
    assert acc.style == pytest.approx(1.0)
    pred = tmp_path / "pred.json"
    pred.write_text("".join(format_record(f) + "\n" for f in flipped))
    res = CliRunner().invoke(app, ["eval", "attributes", str(pred), str(labels), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["color_accuracy"] == 0.0
    res = CliRunner().invoke(
        app, ["eval", "tusimple", str(pred), str(labels), "--mode", "ego", "--json"]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["accuracy"] == pytest.approx(1.0)
    res = CliRunner().invoke(app, ["eval", "tusimple", str(pred), str(labels), "--mode", "x"])
    assert res.exit_code == 2
