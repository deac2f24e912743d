"""Speed paths of ``reprocess``: reduced JPEG decoding, the cached ground grid, CPU timings."""

from __future__ import annotations

import math
import os
import signal
import time
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pandas as pd
import pytest

from superlane_tools.camera.profiles import load_camera
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.corridor import CorridorParams, corridor_from_mask, measurable_range_m
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.errors import ConfigError
from superlane_tools.recording.images import decode_frame, decode_reduced
from superlane_tools.records import Message
from superlane_tools.reporting.layout import STAGES
from superlane_tools.simulation.drive import simulate_drive


def _jpeg_message(image: np.ndarray) -> Message:
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    data = SimpleNamespace(format="jpeg", data=buf.tobytes())
    return Message("/cam", 0, None, "sensor_msgs/msg/CompressedImage", data)


def _road_image(width: int, height: int) -> np.ndarray:
    """A smooth road-like frame: grey gradient, two bright slanted lines."""
    v, _u = np.mgrid[0:height, 0:width].astype(np.float32)
    image = np.dstack([60 + 80 * v / height] * 3).astype(np.uint8)
    for x0 in (0.3, 0.7):
        pts = np.array([[int(x0 * width), height - 1], [width // 2, height // 3]])
        cv2.line(image, tuple(pts[0]), tuple(pts[1]), (230, 230, 230), max(2, width // 160))
    return image


def test_reduced_decode_matches_full_decode_and_resize() -> None:
    image = _road_image(1280, 720)
    msg = _jpeg_message(image)
    reduced = decode_reduced(msg, 640)
    assert reduced is not None
    small, source = reduced
    assert source == (1280, 720)
    assert small.shape == (360, 640, 3)
    assert small.dtype == np.uint8
    reference = cv2.resize(decode_frame(msg), (640, 360), interpolation=cv2.INTER_AREA)
    diff = np.abs(small.astype(np.int16) - reference.astype(np.int16))
    assert float(diff.mean()) < 2.0  # DCT-domain scaling vs area averaging: grey levels
    # A quarter-size target decodes at 1/4; a target above half the width is not reduced.
    quarter = decode_reduced(msg, 300)
    assert quarter is not None
    assert quarter[0].shape == (180, 320, 3)
    assert decode_reduced(msg, 641) is None
    assert decode_reduced(msg, 0) is None


def test_reduced_decode_declines_png_and_corrupt_jpeg() -> None:
    ok, png = cv2.imencode(".png", _road_image(320, 180))
    assert ok
    data = SimpleNamespace(format="png", data=png.tobytes())
    assert decode_reduced(Message("/c", 0, None, "x/CompressedImage", data), 100) is None
    jpeg = _jpeg_message(_road_image(320, 180)).data.data
    broken = SimpleNamespace(format="jpeg", data=jpeg[: len(jpeg) // 2])
    assert decode_reduced(Message("/c", 0, None, "x/CompressedImage", broken), 100) is None


def _per_pixel_reference(prob: np.ndarray, camera: object, p: CorridorParams) -> tuple:
    """The straightforward measurement: back-project every corridor pixel of every frame."""
    cam = camera.resized(prob.shape[1], prob.shape[0])  # type: ignore[attr-defined]
    rows, cols = np.nonzero(prob > p.threshold)
    xy, valid = cam.ground_points(np.stack([cols, rows], axis=1).astype(np.float64))
    rows, xy = rows[valid], xy[valid]
    height = prob.shape[0]
    count = np.bincount(rows, minlength=height)
    x_row = np.bincount(rows, xy[:, 0], height) / np.maximum(count, 1)
    y_min, y_max = np.full(height, np.inf), np.full(height, -np.inf)
    np.minimum.at(y_min, rows, xy[:, 1])
    np.maximum.at(y_max, rows, xy[:, 1])
    support = count >= p.min_row_px
    if not support.any():
        return math.nan, math.nan, 0
    row_width = np.where(support, y_max - y_min, 0.0)
    band = support & (np.abs(x_row - p.width_at_m) <= p.width_band_m)
    ref = float(np.median(row_width[band if band.any() else support]))
    full = np.flatnonzero(support & (row_width >= p.full_width_fraction * ref))[::-1]
    if full.size == 0:
        length = float(x_row[np.flatnonzero(support)[-1]])
    else:
        cut = np.flatnonzero(full[:-1] - full[1:] > p.max_gap_rows + 1)
        length = float(x_row[full[cut[0]] if cut.size else full[-1]])
    at = min(p.width_at_m, length)
    rows = np.flatnonzero(support & (np.abs(x_row - at) <= p.width_band_m) & (x_row <= length))
    if rows.size == 0:
        sup = np.flatnonzero(support)
        rows = sup[np.argmin(np.abs(x_row[sup] - at))][None]
    return float(np.median(row_width[rows])), length, int(support.sum())


@pytest.mark.parametrize("profile", ["kitti", "sim_default"])
def test_corridor_from_mask_equals_per_pixel_measurement(profile: str) -> None:
    camera = load_camera(profile)
    params = CorridorParams()
    rng = np.random.default_rng(5)
    for k in range(4):
        prob = np.zeros((180, 326), np.float32)
        centre, half = int(rng.integers(100, 220)), int(rng.integers(10, 120))
        prob[int(rng.integers(60, 120)) :, max(0, centre - half) : centre + half] = 0.9
        prob += (k % 2) * 0.6 * rng.random(prob.shape, dtype=np.float32)
        got = corridor_from_mask(prob, camera, params)
        want = _per_pixel_reference(prob, camera, params)
        assert got.n_rows == want[2]
        # the length is capped at the camera's measurable range (issue 35 item 3)
        cap = measurable_range_m(camera.resized(prob.shape[1], prob.shape[0]))
        capped = (want[0], float(np.fmin(want[1], cap)))
        assert np.allclose(got[:2], capped, rtol=1e-9, equal_nan=True)


def test_reprocess_reduced_decode_and_cpu_timings(tmp_path: Path) -> None:
    rec = tmp_path / "d.mcap"
    simulate_drive("highway_curves", 1.0, 2, "mcap", 320, 180, False, rec)
    cfg = ReprocessConfig().with_overrides(
        {"segmentation.process_width": 160, "output.plots": False}
    )
    result = reprocess(rec, tmp_path / "run", cfg)
    assert result.status == "ok"
    assert result.frames == 15
    frames = pd.read_parquet(tmp_path / "run" / "frames.parquet")
    assert (frames["width"] == 320).all()
    assert (frames["height"] == 180).all()
    assert (frames["process_width"] == 160).all()
    assert (frames["process_height"] == 90).all()
    for stage in STAGES:
        wall_ms, cpu_ms = frames[f"{stage}_ms"], frames[f"{stage}_cpu_ms"]
        # The totals come from the in-memory record: they must add up to the table's columns.
        assert result.timings[stage] == pytest.approx(wall_ms.sum() / 1e3, rel=1e-9, abs=1e-12)
        assert result.timings[f"cpu_{stage}"] == pytest.approx(cpu_ms.sum() / 1e3, abs=1e-12)
        # One thread's CPU time cannot exceed its wall time (2 ms for the clocks' granularity).
        assert (cpu_ms <= wall_ms + 2.0).all(), stage
    # The stages' thread CPU times are part of the process CPU time of the pass.
    stage_cpu = sum(result.timings[f"cpu_{stage}"] for stage in STAGES)
    assert stage_cpu <= result.timings["cpu_pass"] + 0.05
    assert frames["segmentation_cpu_ms"].sum() > 0
    assert 0 < result.timings["cpu_pass"] <= result.timings["cpu_total"]


def test_look_ahead_while_kernels_load_leaves_results_unchanged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Frames buffered while the fit's kernels compile are fitted exactly as without a buffer."""
    from superlane_tools.drive import stages

    rec = tmp_path / "d.mcap"
    simulate_drive("highway_curves", 3.0, 5, "mcap", 320, 180, False, rec)
    cfg = ReprocessConfig().with_overrides(
        {"segmentation.process_width": 160, "output.plots": False}
    )
    reprocess(rec, tmp_path / "plain", cfg)
    asked: list[bool] = []

    def always_loading(backend: str) -> bool:
        asked.append(backend == "numba")
        return True  # as on a first run: the whole drive may wait for the kernels

    monkeypatch.setattr(stages, "kernels_loading", always_loading)
    reprocess(rec, tmp_path / "ahead", cfg)
    assert asked
    assert all(asked)
    for name in ("lanes.parquet", "corridor.parquet", "frames.parquet"):
        plain = pd.read_parquet(tmp_path / "plain" / name)
        ahead = pd.read_parquet(tmp_path / "ahead" / name)
        timing = [c for c in plain.columns if c.endswith("_ms") or c.endswith("_s")]
        pd.testing.assert_frame_equal(plain.drop(columns=timing), ahead.drop(columns=timing))


def test_look_ahead_is_bounded_while_the_kernels_load(monkeypatch: pytest.MonkeyPatch) -> None:
    """While compiling: up to WARM_UP_LOOK_AHEAD wait, newest awaited; then a gradual catch-up."""
    import threading
    from collections import deque
    from concurrent.futures import Future

    from superlane_tools.drive import stages

    cfg = ReprocessConfig().with_overrides({"segmentation.backend": "classical"})
    frame_stages = stages.FrameStages(cfg, load_camera("sim_default"))
    loading = {"numba": True}
    monkeypatch.setattr(stages, "kernels_loading", lambda backend: loading[backend])

    def prepared(index: int) -> Future[stages.Prepared]:
        future: Future[stages.Prepared] = Future()
        future.set_result(stages.Prepared(index, index, None))
        return future

    n = stages.WARM_UP_LOOK_AHEAD + 40
    pending = deque(prepared(i) for i in range(n - 1))
    newest: Future[stages.Prepared] = Future()
    pending.append(newest)
    threading.Timer(0.2, newest.set_result, [stages.Prepared(n - 1, n - 1, None)]).start()
    taken = [p.index for p in frame_stages.due(pending, 2)]
    assert newest.done()  # one core prepares while the compiler has the other
    assert taken == list(range(40))
    assert len(pending) == stages.WARM_UP_LOOK_AHEAD
    loading["numba"] = False
    assert [p.index for p in frame_stages.due(pending, 2)] == [40, 41]  # CATCH_UP per call
    while len(pending) > 4:
        assert len(list(frame_stages.due(pending, 2))) == stages.CATCH_UP
    assert list(frame_stages.due(pending, 2)) == []
    assert [f.result().index for f in pending] == list(range(n - 4, n))
    pending.extend(prepared(n + i) for i in range(300))
    assert len(list(frame_stages.due(pending, 100))) == stages.CATCH_UP


def test_blas_pool_held_to_one_and_restored() -> None:
    from threadpoolctl import threadpool_info

    from superlane_tools.commands.reprocess._threads import single_native_threads

    before_cv2 = cv2.getNumThreads()
    before_blas = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
    with single_native_threads():
        inside = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
        assert inside
        assert set(inside) == {1}
        assert cv2.getNumThreads() == before_cv2  # OpenCV's pool is not touched (fork safety)
    assert [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] == before_blas


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_thread_limits_do_not_hang_in_a_forked_child() -> None:
    """A child forked after the parent's OpenCV pool ran enters the limits and leaves promptly.

    ``cv2.setNumThreads`` in such a child blocked forever (the fuzz suite's reprocess hangs).
    """
    from superlane_tools.commands.reprocess._threads import single_native_threads

    big = np.zeros((2000, 2000, 3), np.uint8)
    for _ in range(5):  # start OpenCV's worker threads in this (the parent) process
        cv2.resize(big, (1000, 1000), interpolation=cv2.INTER_AREA)
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            with single_native_threads():
                cv2.resize(big, (640, 360), interpolation=cv2.INTER_AREA)
            code = 0
        finally:
            os._exit(code)
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    pytest.fail("the forked child hung inside single_native_threads()")


def test_corridor_net_every_second_frame(tmp_path: Path) -> None:
    rec = tmp_path / "d.mcap"
    simulate_drive("highway_curves", 1.0, 2, "mcap", 320, 180, False, rec)
    runs = {}
    for every in (1, 2):
        cfg = ReprocessConfig().with_overrides(
            {"segmentation.process_width": 160, "output.plots": False, "corridor.net_every": every}
        )
        assert reprocess(rec, tmp_path / f"e{every}", cfg).status == "ok"
        runs[every] = (
            pd.read_parquet(tmp_path / f"e{every}" / "corridor.parquet"),
            pd.read_parquet(tmp_path / f"e{every}" / "frames.parquet"),
        )
    (corr1, frames1), (corr2, frames2) = runs[1], runs[2]
    # Every frame still gets a corridor from the mean; the network ran on even frames only.
    assert corr2["width_m"].notna().sum() == corr1["width_m"].notna().sum()
    odd = frames2["frame_index"] % 2 == 1
    assert frames2.loc[odd, "corridor_net_cpu_ms"].max() < frames1["corridor_net_cpu_ms"].min()
    # Frame 0 is the same (network run, nothing held yet); frame 1 holds frame 0's output.
    assert corr2["width_m"].iloc[0] == corr1["width_m"].iloc[0]
    with pytest.raises(ConfigError, match="net_every"):
        ReprocessConfig().with_overrides({"corridor.net_every": 0})
