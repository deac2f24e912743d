"""The one frame reader: every frame, chosen times, reduced decoding, video, corrupt frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from superlane_tools.recording import messages as m
from superlane_tools.recording import open_recording
from superlane_tools.recording.camera_frames import camera_frames
from superlane_tools.recording.video import VideoEncoder
from superlane_tools.recording.writers import open_writer

SAMPLE = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"
TOPIC = "/camera/image/compressed"
T0 = 1_700_000_000_000_000_000
STEP = 100_000_000


def test_every_frame_at_full_size() -> None:
    with open_recording(SAMPLE) as rec:
        frames = list(camera_frames(rec, TOPIC))
    assert len(frames) == 240
    times = [f.log_time_ns for f in frames]
    assert times == sorted(times)
    assert all(f.error == "" and f.size == (960, 540) for f in frames)
    assert frames[0].image is not None
    assert frames[0].image.shape == (540, 960, 3)


def test_chosen_times_reduced() -> None:
    with open_recording(SAMPLE) as rec:
        every = [f.log_time_ns for f in camera_frames(rec, TOPIC)]
        wanted = [every[3], every[100], every[101], every[239]]
        got = list(camera_frames(rec, TOPIC, wanted, width=300))
        assert list(camera_frames(rec, TOPIC, [])) == []
    assert [f.log_time_ns for f in got] == wanted
    for frame in got:
        assert frame.size == (960, 540)  # the recorded size, not the decoded one
        assert frame.image is not None
        assert frame.image.shape == (270, 480, 3)


def _write(path: Path, payloads: list[bytes], fmt: str) -> None:
    with open_writer(path, "mcap") as w:
        w.add_topic("/cam", "foxglove_msgs/msg/CompressedVideo")
        for i, payload in enumerate(payloads):
            t = T0 + i * STEP
            w.write("/cam", t, m.compressed_video(t, "cam", fmt, payload))


def test_video_frames_are_decoded_and_a_seek_starts_at_a_keyframe(tmp_path: Path) -> None:
    yy, xx = np.mgrid[0:96, 0:160]
    images = [
        np.dstack([(xx + 4 * i) % 256, (yy * 2) % 256, np.full_like(xx, 40 + 5 * i)]).astype(
            np.uint8
        )
        for i in range(12)
    ]
    enc = VideoEncoder("h264", 160, 96, 10.0, crf=18, gop=5)
    path = tmp_path / "video.mcap"
    _write(path, [enc.encode(img) for img in images], "h264")
    with open_recording(path) as rec:
        every = list(camera_frames(rec, "/cam"))
        later = list(camera_frames(rec, "/cam", [T0 + 7 * STEP, T0 + 8 * STEP], width=80))
    assert len(every) == 12
    for frame, src in zip(every, images, strict=True):
        assert frame.image is not None
        assert frame.size == (160, 96)
        assert np.abs(frame.image.astype(int) - src.astype(int)).mean() < 6.0
    assert [f.log_time_ns for f in later] == [T0 + 7 * STEP, T0 + 8 * STEP]
    assert all(f.image is not None and f.image.shape == (96, 160, 3) for f in later)


def test_a_corrupt_frame_keeps_its_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.mcap"
    good = _jpeg()
    with open_writer(path, "mcap") as w:
        w.add_topic("/cam", "sensor_msgs/msg/CompressedImage")
        for i, payload in enumerate([good, b"\xff\xd8not a jpeg", good]):
            t = T0 + i * STEP
            w.write("/cam", t, m.compressed_image(t, "cam", "jpeg", payload))
    with open_recording(path) as rec:
        frames = list(camera_frames(rec, "/cam", width=16))
    assert [f.image is None for f in frames] == [False, True, False]
    assert frames[1].error
    assert frames[1].size == (0, 0)


def _jpeg() -> bytes:
    import cv2

    ok, buffer = cv2.imencode(".jpg", np.full((64, 96, 3), 128, np.uint8))
    assert ok
    return bytes(buffer)
