"""The TuSimple metric: each official rule pinned by a hand-made case, real label files, CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.evaluation import (
    EvaluationError,
    TuSimpleRecord,
    bench,
    evaluate,
    evaluate_frames,
    f1_from_rates,
    format_record,
    lane_angle,
    line_accuracy,
    load_jsonl,
)

ROWS = [float(r) for r in range(160, 720, 10)]  # 56 rows
N = len(ROWS)


def vertical(x: float, missing: int = 0) -> list[float]:
    """A vertical lane at column x with the first ``missing`` rows unlabelled."""
    return [-2.0] * missing + [x] * (N - missing)


def test_identical_lanes_score_perfectly() -> None:
    gt = [vertical(300), vertical(600), vertical(900)]
    assert bench(gt, gt, ROWS, 0.0) == (1.0, 0.0, 0.0)


def test_pixel_threshold_is_strictly_below_20_px_for_vertical_lanes() -> None:
    gt = [vertical(500)]
    assert bench([vertical(519.9)], gt, ROWS, 0) == (1.0, 0.0, 0.0)
    acc, fp, fn = bench([vertical(520.0)], gt, ROWS, 0)  # |d| = 20 is not < 20
    assert (acc, fp, fn) == (0.0, 1.0, 1.0)


def test_threshold_widens_with_the_lane_angle() -> None:
    slope = 1.0  # x = y: 45 degrees, threshold 20 / cos(45 deg) = 28.28 px
    gt = [[100.0 + slope * r for r in ROWS]]
    assert lane_angle(gt[0], ROWS) == pytest.approx(math.pi / 4)
    inside = [[x + 28.0 for x in gt[0]]]
    outside = [[x + 28.5 for x in gt[0]]]
    assert bench(inside, gt, ROWS, 0)[0] == 1.0
    assert bench(outside, gt, ROWS, 0)[0] == 0.0


def test_angle_comes_from_valid_points_only_and_is_zero_for_one_point() -> None:
    lane = [-2.0] * (N - 10) + [100.0 + 2 * r for r in ROWS[-10:]]
    assert lane_angle(lane, ROWS) == pytest.approx(math.atan(2.0))
    single = [-2.0] * (N - 1) + [300.0]
    assert lane_angle(single, ROWS) == 0.0


def test_missing_points_match_each_other_and_count_in_the_denominator() -> None:
    gt = vertical(400, missing=10)
    assert line_accuracy(vertical(400, missing=10), gt, 20) == 1.0
    # the prediction has points where the GT has none: 10 of 56 rows miss
    assert line_accuracy(vertical(400), gt, 20) == pytest.approx((N - 10) / N)


def test_point_accuracy_threshold_is_0_85() -> None:
    gt = [vertical(500)]
    n_ok = math.ceil(0.85 * N)  # 48 of 56 rows = 0.857 -> found
    found = [[500.0] * n_ok + [900.0] * (N - n_ok)]
    lost = [[500.0] * (n_ok - 1) + [900.0] * (N - n_ok + 1)]  # 47 / 56 = 0.839
    acc, fp, fn = bench(found, gt, ROWS, 0)
    assert (acc, fp, fn) == (pytest.approx(n_ok / N), 0.0, 0.0)
    acc, fp, fn = bench(lost, gt, ROWS, 0)
    assert (acc, fp, fn) == (pytest.approx((n_ok - 1) / N), 1.0, 1.0)


def test_each_gt_lane_takes_its_best_prediction_and_fp_counts_unmatched() -> None:
    gt = [vertical(300), vertical(600)]
    pred = [vertical(605), vertical(1000), vertical(302)]
    acc, fp, fn = bench(pred, gt, ROWS, 0)
    assert (acc, fp, fn) == (1.0, pytest.approx(1 / 3), 0.0)


def test_more_than_four_gt_lanes_forgive_one_fn_and_drop_the_worst_lane() -> None:
    gt = [vertical(x) for x in (100, 350, 600, 850, 1100)]
    pred = [vertical(x) for x in (100, 350, 600, 850)]
    acc, fp, fn = bench(pred, gt, ROWS, 0)
    assert (acc, fp, fn) == (1.0, 0.0, 0.0)  # (5 - 0) / 4 accuracy, fn 1 - 1
    pred3 = [vertical(x) for x in (100, 350, 600)]
    acc, fp, fn = bench(pred3, gt, ROWS, 0)
    assert acc == pytest.approx(3 / 4)  # (3 + 0 + 0 - 0) / min(4, 5)
    assert fn == pytest.approx(1 / 4)  # (2 - 1) / min(5, 4)
    assert fp == 0.0


def test_slow_frames_and_too_many_predictions_score_zero() -> None:
    gt = [vertical(300), vertical(600)]
    assert bench(gt, gt, ROWS, 200.0) == (1.0, 0.0, 0.0)
    assert bench(gt, gt, ROWS, 200.1) == (0.0, 0.0, 1.0)
    four = [*gt, vertical(900), vertical(1100)]  # len(gt) + 2 is still fine
    assert bench(four, gt, ROWS, 0)[0] == 1.0
    five = [*four, vertical(50)]
    assert bench(five, gt, ROWS, 0) == (0.0, 0.0, 1.0)


def test_empty_prediction_and_empty_gt() -> None:
    gt = [vertical(300), vertical(600)]
    assert bench([], gt, ROWS, 0) == (0.0, 0.0, 1.0)
    assert bench([vertical(300)], [], ROWS, 0) == (0.0, 1.0, 0.0)
    assert bench([], [], ROWS, 0) == (0.0, 0.0, 0.0)


def test_lane_length_mismatch_is_a_format_error() -> None:
    with pytest.raises(EvaluationError, match="format of lanes"):
        bench([[1.0, 2.0]], [vertical(300)], ROWS, 0)


def test_f1_formula() -> None:
    assert f1_from_rates(0.0, 0.0) == 1.0
    # tp = 0.9, P = 0.9, R = 0.9 / 0.95
    p, r = 0.9, 0.9 / 0.95
    assert f1_from_rates(0.1, 0.05) == pytest.approx(2 * p * r / (p + r))
    assert f1_from_rates(1.0, 1.0) == 0.0


def _records(path: Path, limit: int | None = None) -> list[TuSimpleRecord]:
    return load_jsonl(path)[:limit]


@pytest.mark.parametrize(
    ("rel", "limit"),
    [("tusimple/frames/labels.json", None), ("tusimple/train_labels/label_data_0313.json", 300)],
)
def test_ground_truth_against_itself_is_perfect(
    realdata: Path, rel: str, limit: int | None
) -> None:
    gt = _records(realdata / rel, limit)
    score = evaluate(gt, gt)
    assert (score.accuracy, score.fp, score.fn, score.f1) == (1.0, 0.0, 0.0, 1.0)
    assert score.n_frames == len(gt)


def _shift(records: list[TuSimpleRecord], dx: float) -> list[TuSimpleRecord]:
    return [
        rec._replace(lanes=[[x + dx if x >= 0 else x for x in lane] for lane in rec.lanes])
        for rec in records
    ]


def test_shifted_prediction_fails(realdata: Path) -> None:
    gt = _records(realdata / "tusimple/train_labels/label_data_0601.json", 200)
    score = evaluate(_shift(gt, 25.0), gt)
    assert score.accuracy < 1.0
    assert score.fn > 0.0
    assert score.f1 < 1.0
    # Lanes slanted in the image (20 / cos(angle) > 25 px) survive a 25 px shift; the upright
    # ones (ego lanes) are lost, except short ones whose unlabelled rows (-2 vs -2 match)
    # alone reach 85 %.
    upright = [
        rec._replace(
            lanes=[
                lane
                for lane in rec.lanes
                if 20.0 / math.cos(lane_angle(lane, rec.h_samples)) < 25.0
            ]
        )
        for rec in gt
    ]
    upright = [rec for rec in upright if rec.lanes]
    assert len(upright) >= 20
    near_vertical = evaluate(_shift(upright, 25.0), upright)
    assert near_vertical.fn > 0.9
    assert near_vertical.fp > 0.9
    assert near_vertical.accuracy < 0.85
    far = evaluate(_shift(gt, 60.0), gt)
    assert far.accuracy < 0.7  # unlabelled rows still "match"
    assert far.fn > 0.5
    assert evaluate(_shift(gt, 10.0), gt).accuracy == 1.0


def test_missing_unknown_and_duplicate_frames_raise() -> None:
    a = TuSimpleRecord("a.jpg", [vertical(300)], ROWS)
    b = TuSimpleRecord("b.jpg", [vertical(300)], ROWS)
    with pytest.raises(EvaluationError, match=r"missing 1 of 2 ground-truth frame.*b\.jpg"):
        evaluate([a], [a, b])
    with pytest.raises(EvaluationError, match=r"not in the ground truth.*b\.jpg"):
        evaluate([a, b], [a])
    with pytest.raises(EvaluationError, match="appears more than once"):
        evaluate([a, a], [a])
    bad = TuSimpleRecord("a.jpg", [[1.0]], ROWS)
    with pytest.raises(EvaluationError, match=r"a\.jpg: format of lanes"):
        evaluate_frames([bad], [a])


def test_run_time_counts_per_frame() -> None:
    gt = [TuSimpleRecord(f"{i}.jpg", [vertical(300)], ROWS) for i in range(4)]
    pred = [rec._replace(run_time_ms=250.0 if i == 0 else 5.0) for i, rec in enumerate(gt)]
    score = evaluate(pred, gt)
    assert score.accuracy == pytest.approx(0.75)
    assert score.fn == pytest.approx(0.25)


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_load_jsonl_round_trips_and_names_bad_lines(tmp_path: Path) -> None:
    rec = TuSimpleRecord("clips/x/20.jpg", [[-2.0, 10.5, 11.0]], [240.0, 250.0, 260.0], 3.0)
    path = _write(tmp_path / "p.json", [format_record(rec), ""])
    assert load_jsonl(path) == [rec]
    assert json.loads(format_record(rec))["lanes"] == [[-2, 10.5, 11]]
    cases = {
        "{not json": "2: not valid JSON",
        "[1, 2]": "2: expected a JSON object",
        '{"lanes": []}': "2: missing or non-string 'raw_file'",
        '{"raw_file": "a", "lanes": [[1, "x"]], "h_samples": [1]}': "2: 'lanes' must be",
        '{"raw_file": "a", "lanes": []}': "2: 'h_samples' must be",
        '{"raw_file": "a", "lanes": [], "h_samples": [], "run_time": "fast"}': "run_time",
    }
    for line, match in cases.items():
        bad = _write(tmp_path / "bad.json", [format_record(rec), line])
        with pytest.raises(EvaluationError, match=match):
            load_jsonl(bad)
    no_h = _write(tmp_path / "noh.json", ['{"raw_file": "a", "lanes": [[1, 2]]}'])
    assert load_jsonl(no_h, require_h_samples=False)[0].h_samples == []
    with pytest.raises(EvaluationError, match="no frames"):
        load_jsonl(_write(tmp_path / "empty.json", [""]))
    with pytest.raises(EvaluationError, match="cannot read"):
        load_jsonl(tmp_path / "missing.json")


runner = CliRunner()


def test_cli_scores_a_file_against_itself(realdata: Path) -> None:
    gt = realdata / "tusimple" / "frames" / "labels.json"
    result = runner.invoke(app, ["eval", "tusimple", str(gt), str(gt), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout) == {
        "accuracy": 1.0,
        "fp": 0.0,
        "fn": 0.0,
        "f1": 1.0,
        "n_frames": 6,
    }
    result = runner.invoke(app, ["eval", "tusimple", str(gt), str(gt)])
    assert result.exit_code == 0
    assert "accuracy  1.0000" in result.stdout
    assert "F1        1.0000" in result.stdout


def test_cli_prints_one_line_and_exits_1_on_bad_input(tmp_path: Path) -> None:
    gt_rec = TuSimpleRecord("a.jpg", [vertical(300)], ROWS)
    gt = _write(tmp_path / "gt.json", [format_record(gt_rec)])
    bad = _write(tmp_path / "pred.json", ["{oops"])
    for args in ([str(bad), str(gt)], [str(tmp_path / "none.json"), str(gt)]):
        result = runner.invoke(app, ["eval", "tusimple", *args])
        assert result.exit_code == 1
        assert result.stderr.count("\n") == 1
        assert result.stderr.startswith("slt: error: ")
        assert "Traceback" not in result.output


def test_score_is_stable_under_point_shuffles_of_prediction_order() -> None:
    rng = np.random.default_rng(3)
    gt = [vertical(x) for x in (200, 500, 800, 1100)]
    pred = [[x + rng.normal(0, 8) for x in lane] for lane in gt]
    a = bench(pred, gt, ROWS, 0)
    b = bench(pred[::-1], gt, ROWS, 0)
    assert a == b
