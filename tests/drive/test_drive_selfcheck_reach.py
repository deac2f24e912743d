"""The self-check sees reach and ties, and serves the demo drive with the backend that suits it."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.drive.selfcheck import TIE, SelfCheck, Trial, choose, drive_self_check
from superlane_tools.lanes.plausibility import Plausibility, Reach, plausibility
from superlane_tools.lanes.result import Lane, LaneFit

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "fixtures" / "sample_drive.mcap"
runner = CliRunner()


def _scores(score: float, available: float = 1.0) -> Plausibility:
    return Plausibility(16, 1.0, 3.6, 1.0, 0.1, 1.0, 1.0, 0.98, score, "", 30.0, 1.0, available)


def _fit(reach_m: float) -> LaneFit:
    lanes = (Lane(1.8, 0.0, 0.0, 5.0, reach_m), Lane(-1.8, 0.0, 0.0, 5.0, reach_m))
    return LaneFit(a1=0.0, a2=0.0, b=0.0, lanes=lanes, ego_left=0, ego_right=1, quality=0.98)


def test_short_lanes_score_lower_than_long_ones() -> None:
    need = 17.5
    far = plausibility([[_fit(40.0)] * 2] * 4, reach=Reach([40.0] * 8, [True] * 8, need))
    near = plausibility([[_fit(15.0)] * 2] * 4, reach=Reach([15.0] * 8, [False] * 8, need))
    assert far.plausible
    assert near.plausible  # the geometry alone is fine ...
    assert far.available == 1.0
    assert near.available == 0.0
    assert near.reach_share == pytest.approx(15.0 / need)
    assert near.score < far.score  # ... but it does not serve the drive
    assert "reach 15.0 m, available 0%" in near.summary()


def test_a_tie_keeps_the_faster_backend() -> None:
    slow = Trial("onnx", "super_seg_v5", _scores(0.95), cpu_ms=45.0)
    fast = Trial("onnx", "super_seg_v4", _scores(0.95 - TIE / 2), cpu_ms=15.0)
    best, why = choose([slow, fast], ("onnx", "super_seg_v4"))
    assert best is fast
    assert "tied with onnx:super_seg_v5" in why
    assert "faster (less CPU per sample frame)" in why
    clear = Trial("onnx", "super_seg_v5", _scores(0.99), cpu_ms=45.0)
    best, _ = choose([clear, Trial("classical", "", _scores(0.90), cpu_ms=5.0)], ("classical", ""))
    assert best is clear  # beyond the tie, the more plausible one wins whatever its cost


def test_the_reason_is_one_line_and_the_report_leads_with_it() -> None:
    trial = Trial("onnx", "super_seg_v4", _scores(0.97), cpu_ms=20.0)
    _, why = choose([trial], ("onnx", "super_seg_v4"))
    check = SelfCheck("onnx", "super_seg_v4", (trial,), True, why, 16, 0.5, 0.25)
    line = check.reason_line()
    assert "\n" not in line
    assert "onnx:super_seg_v4 ran it" in line
    assert "reach 30.0 m" in line
    assert check.lines()[0] == line


@pytest.mark.slow
def test_the_demo_drive_is_served_by_v4_again(tmp_path: Path) -> None:
    """fixtures/sample_drive.mcap: v4 98.8 % SUPER availability, v5 36.2 % (lanes too short)."""
    run = tmp_path / "run"
    result = runner.invoke(app, ["reprocess", str(SAMPLE), "-o", str(run), "--no-plots"])
    assert result.exit_code == 0, result.stderr
    seq = pq.read_table(run / "availability_sequences.parquet").to_pylist()
    ratio = next(r["ratio"] for r in seq if r["method"] == "super")
    assert ratio >= 0.98
    assert "onnx:super_seg_v4 ran it" in result.stderr


@pytest.mark.slow
def test_the_self_check_costs_little_cpu() -> None:
    from superlane_tools.drive.config import ReprocessConfig
    from superlane_tools.drive.loop import drive_topics
    from superlane_tools.recording import open_recording
    from superlane_tools.recording.calibration import resolve_camera

    cfg = ReprocessConfig()
    with open_recording(SAMPLE) as rec:
        topics = drive_topics(rec, cfg.topics)
        camera, _ = resolve_camera(rec, topics.streams, cfg.camera)
        drive_self_check(rec, topics.frames, cfg, camera)  # imports, kernels: a run's set-up
        c0 = time.process_time()
        check = drive_self_check(rec, topics.frames, cfg, camera)
        cpu = time.process_time() - c0
    assert isinstance(check, SelfCheck)
    assert check.model == "super_seg_v4"
    assert math.isclose(check.cpu_s, cpu, rel_tol=0.1, abs_tol=0.05)
    assert cpu < 1.5  # generous: 0.3 s is the goal on a quiet machine (docs/models.md)
