"""The per-drive segmentation self-check (``drive.selfcheck``) on real recordings, no mocks."""

from __future__ import annotations

import importlib.util
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.drive.selfcheck import sample_frames, sample_starts
from superlane_tools.reporting import read_provenance
from superlane_tools.reporting.drive_notes import UNLIKE_TRAINING_DATA
from superlane_tools.simulation.drive import simulate_drive

REPO = Path(__file__).resolve().parents[2]
runner = CliRunner()
UNLIKE = UNLIKE_TRAINING_DATA.split(";")[0]


def test_the_sample_is_spread_evenly_over_the_drive() -> None:
    assert sample_starts(100) == [0, 20, 39, 59, 78, 98]
    assert sample_starts(5) == [0, 3]
    assert sample_starts(12) == [0, 2, 4, 6, 8, 10]
    assert sample_starts(2) == [0]
    assert sample_starts(1) == [0]
    assert sample_starts(0) == []
    runs = sample_frames(iter(range(100)), 100)  # type: ignore[arg-type]
    assert [[i for i, _ in run] for run in runs][:2] == [[0, 1], [20, 21]]
    assert sum(len(run) for run in runs) == 12


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 4 s simulated highway drive at 320x180 (its camera profile in the MCAP)."""
    out = tmp_path_factory.mktemp("selfcheck") / "curves.mcap"
    simulate_drive("highway_curves", 4.0, 3, "mcap", 320, 180, False, out)
    return out


def _reprocess(rec: Path, out: Path, *extra: str) -> tuple[str, str, int]:
    args = ["reprocess", str(rec), "-o", str(out), "--no-plots", *extra]
    result = runner.invoke(app, args)
    return result.stdout, result.stderr, result.exit_code


def _self_check(run: Path, table: str = "lanes") -> Any:
    """The self-check recorded in a run's Parquet provenance."""
    return read_provenance(run / f"{table}.parquet")["config"]["resolved"][
        "segmentation_self_check"
    ]


@pytest.mark.slow
def test_a_correct_camera_gets_a_plausible_backend_with_its_scores(
    drive: Path, tmp_path: Path
) -> None:
    run = tmp_path / "run"
    _, stderr, code = _reprocess(drive, run)
    assert code == 0, stderr
    check = _self_check(run)
    assert check["plausible"] is True
    assert check["n_frames"] == 12
    trials = check["trials"]
    assert isinstance(trials, list)
    assert trials  # the fastest candidate at least; later ones only when it leaves room
    assert "not tried" in check["reason"] or {t["backend"] for t in trials} >= {"classical"}
    chosen = [t for t in trials if (t["backend"], t["model"]) == (check["backend"], check["model"])]
    assert chosen[0]["scores"]["plausible"] is True
    assert 2.5 <= chosen[0]["scores"]["width_m"] <= 4.5
    report = (run / "report.md").read_text(encoding="utf-8")
    assert "segmentation self-check on 12 frames" in report
    assert "most plausible lanes" in report
    assert UNLIKE not in report
    assert UNLIKE not in stderr
    assert _self_check(run, "frames") == check  # every Parquet output carries it


@pytest.mark.slow
def test_a_wrong_camera_profile_makes_no_backend_plausible_and_the_headline_says_so(
    drive: Path, tmp_path: Path
) -> None:
    """The camera 2.2 times higher than it is: every width comes out 2.2 times too wide."""
    from superlane_tools.camera import camera_to_yaml, load_camera
    from superlane_tools.drive.config import TopicsConfig
    from superlane_tools.drive.loop import drive_topics
    from superlane_tools.recording import open_recording
    from superlane_tools.recording.calibration import resolve_camera

    with open_recording(drive) as rec:
        camera, _ = resolve_camera(rec, drive_topics(rec, TopicsConfig()).streams, "auto")
    wrong = replace(camera, extrinsics=replace(camera.extrinsics, height_m=3.3))
    profile = tmp_path / "wrong.yaml"
    profile.write_text(camera_to_yaml(wrong), encoding="utf-8")
    assert load_camera(profile).extrinsics.height_m == 3.3
    run = tmp_path / "run"
    _, stderr, code = _reprocess(drive, run, "--camera", str(profile))
    assert code == 0, stderr
    check = _self_check(run)
    assert check["plausible"] is False
    assert all(not t["scores"]["plausible"] for t in check["trials"])
    report = (run / "report.md").read_text(encoding="utf-8")
    headline = report.split("## Headline", 1)[1].split("##", 1)[0]
    assert UNLIKE_TRAINING_DATA in headline
    assert "ego width" in headline
    assert f"slt: note: Lanes not plausible: {UNLIKE}" in stderr
    html = (run / "report.html").read_text(encoding="utf-8")
    assert "slt camera estimate" in html


@pytest.mark.slow
def test_an_explicit_backend_skips_the_self_check(drive: Path, tmp_path: Path) -> None:
    run = tmp_path / "run"
    _, stderr, code = _reprocess(drive, run, "--backend", "classical")
    assert code == 0, stderr
    assert _self_check(run).startswith("segmentation self-check skipped")
    assert "self-check skipped: backend chosen explicitly (--backend classical)" in (
        run / "report.md"
    ).read_text(encoding="utf-8")


def test_the_pass_reuses_the_chosen_backend_and_its_sample_exactly(
    drive: Path, tmp_path: Path
) -> None:
    """The sample frames the chosen backend segmented are not segmented again: same results."""
    auto, chosen = tmp_path / "auto", tmp_path / "chosen"
    _, stderr, code = _reprocess(drive, auto)
    assert code == 0, stderr
    check = _self_check(auto)
    explicit = ("--model", check["model"]) if check["model"] else ("--backend", check["backend"])
    _, stderr2, code = _reprocess(drive, chosen, *explicit)
    assert code == 0, stderr2
    assert "self-check cost:" in stderr
    assert f"the pass reused {check['n_frames']} of its segmented sample frames" in stderr
    assert "reused" not in stderr2  # no self-check, nothing to reuse
    import runpy

    compare = runpy.run_path(str(REPO / "pipelines" / "compare_runs.py"))["compare_runs"]
    compared, diffs = compare(auto, chosen)  # cell by cell, measured times aside
    assert {"lanes.parquet", "frames.parquet", "availability_frames.parquet"} <= set(compared)
    assert [d for d in diffs if not d.startswith("report.md")] == []  # its self-check lines


def _mp4_writer() -> Any:
    """The dashcam MP4 writer of the convert tests (one encoder for every test)."""
    spec = importlib.util.spec_from_file_location(
        "_rec_convert", REPO / "tests/recording/test_rec_convert.py"
    )
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module._mp4


@pytest.mark.slow
def test_a_real_tusimple_clip_gets_a_plausible_backend(realdata: Path, tmp_path: Path) -> None:
    """20 real TuSimple frames (1280x720) as a dashcam MP4, converted, then reprocessed."""
    import cv2

    folder = realdata / "tusimple" / "train_frames" / "images"
    images = [cv2.imread(str(p)) for p in sorted(folder.glob("*.jpg"))[:20]]
    assert all(img is not None for img in images)
    mp4 = _mp4_writer()(tmp_path / "tusimple.mp4", images, fps=10)
    rec = tmp_path / "tusimple.mcap"
    conv = runner.invoke(app, ["convert", str(mp4), "-o", str(rec), "--camera", "tusimple"])
    assert conv.exit_code == 0, conv.output
    run = tmp_path / "run"
    _, stderr, code = _reprocess(rec, run, "--camera", "tusimple")
    assert code in (0, 3), stderr
    check = _self_check(run)
    assert check["plausible"] is True, json.dumps(check, indent=1)
    widths = [t["scores"]["width_m"] for t in check["trials"] if t["scores"]]
    assert np.nanmax(widths) < 4.5
    assert "most plausible lanes" in (run / "report.md").read_text(encoding="utf-8")


def test_the_self_check_reads_the_open_recording_and_counts_no_loss_twice(
    tmp_path: Path,
) -> None:
    from superlane_tools.drive.config import ReprocessConfig
    from superlane_tools.drive.loop import drive_topics
    from superlane_tools.drive.selfcheck import SelfCheck, drive_self_check
    from superlane_tools.recording import open_recording
    from superlane_tools.recording.calibration import resolve_camera

    cut = tmp_path / "cut.mcap"  # the first chunks of the 240 frames: a truncated file
    cut.write_bytes((REPO / "fixtures" / "sample_drive.mcap").read_bytes()[:2_000_000])
    cfg = ReprocessConfig()
    with open_recording(cut) as fresh:
        topics = drive_topics(fresh, cfg.topics)
        n_frames = sum(1 for _ in fresh.messages(topics=[topics.frames]))
        alone = fresh.skipped
    with open_recording(cut) as rec:
        camera, _ = resolve_camera(rec, topics.streams, cfg.camera)
        check = drive_self_check(rec, topics.frames, cfg, camera)
        assert sum(1 for _ in rec.messages(topics=[topics.frames])) == n_frames
        after_check = rec.skipped
    assert isinstance(check, SelfCheck)
    assert check.n_frames == 12
    assert any("truncated" in s.what for s in alone)
    assert after_check == alone  # the sample's reading is not counted on top of the pass
