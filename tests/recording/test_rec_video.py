"""Compressed video in recordings: PyAV encode/decode, keyframes, seeking, every frame reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from superlane_tools.commands.extract import ExtractConfig, extract
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.recording import messages as m
from superlane_tools.recording import open_recording
from superlane_tools.recording.video import (
    BEFORE_KEYFRAME,
    DECODED_MSGTYPE,
    VideoDecoder,
    VideoEncoder,
    decode_video,
    decoder_available,
    is_keyframe,
    read_with_video,
    video_codec,
)
from superlane_tools.recording.writers import open_writer
from superlane_tools.scene.recording_frames import RecordingFrames
from superlane_tools.simulation.drive import simulate_drive

T0 = 1_700_000_000_000_000_000
STEP = 100_000_000
GOP = 5


def _frames(n: int, width: int = 160, height: int = 96) -> list[np.ndarray]:
    """Smooth moving gradients (compress well, decode close to the source)."""
    yy, xx = np.mgrid[0:height, 0:width]
    return [
        np.dstack([(xx + 4 * i) % 256, (yy * 2) % 256, np.full_like(xx, 40 + 5 * i)]).astype(
            np.uint8
        )
        for i in range(n)
    ]


def _write_video(path: Path, msgtype: str, fmt: str = "h264", n: int = 12) -> list[np.ndarray]:
    frames = _frames(n)
    enc = VideoEncoder(fmt, 160, 96, 10.0, crf=18, gop=GOP)
    with open_writer(path, "mcap") as w:
        w.add_topic("/cam", msgtype)
        w.add_topic("/other", "sensor_msgs/msg/NavSatFix")
        for i, img in enumerate(frames):
            t = T0 + i * STEP
            au = enc.encode(img)
            msg = (
                m.compressed_video(t, "cam", fmt, au)
                if msgtype.startswith("foxglove")
                else m.compressed_image(t, "cam", fmt, au)
            )
            w.write("/cam", t, msg)
            w.write("/other", t + 1, m.navsatfix(t + 1, "gnss", 48.0, 11.0, 500.0))
    return frames


@pytest.mark.parametrize(("fmt", "codec"), [("h264", "h264"), ("h265", "hevc")])
def test_decoder_skips_until_the_first_keyframe(fmt: str, codec: str) -> None:
    frames = _frames(12)
    enc = VideoEncoder(fmt, 160, 96, 10.0, crf=18, gop=GOP)
    units = [enc.encode(f) for f in frames]
    assert [is_keyframe(codec, u) for u in units] == [i % GOP == 0 for i in range(12)]
    dec = VideoDecoder(codec)
    out = []
    for i, unit in enumerate(units[2:], start=2):  # the stream starts mid-GOP
        out += dec.feed(i, None, unit)
    out += dec.flush()
    assert [o.log_time_ns for o in out] == list(range(2, 12))
    assert [o.skipped for o in out[:3]] == [BEFORE_KEYFRAME] * 3
    for o in out[3:]:
        assert o.image is not None
        assert o.skipped == ""
        err = np.abs(o.image.astype(int) - frames[o.log_time_ns].astype(int)).mean()
        assert err < 6.0, f"frame {o.log_time_ns}: mean abs error {err:.1f}"


def test_decoder_reports_a_corrupt_payload_and_recovers() -> None:
    frames = _frames(10)
    enc = VideoEncoder("h264", 160, 96, 10.0, gop=GOP)
    units = [enc.encode(f) for f in frames]
    dec = VideoDecoder("h264")
    out = []
    for i, unit in enumerate(units):
        out += dec.feed(i, None, b"" if i == 2 else unit)
    out += dec.flush()
    by_time = {o.log_time_ns: o for o in out}
    assert by_time[2].skipped == "empty video payload"
    assert by_time[GOP].image is not None  # the next keyframe decodes again


def test_video_codec_names() -> None:
    assert video_codec("foxglove.CompressedVideo", "h264") == "h264"
    assert video_codec("foxglove_msgs/msg/CompressedVideo", "h265") == "hevc"
    assert video_codec("sensor_msgs/msg/CompressedImage", "h264") == "h264"
    assert video_codec("sensor_msgs/msg/CompressedImage", "jpeg") is None
    assert video_codec("sensor_msgs/msg/NavSatFix", "h264") is None


@pytest.mark.parametrize(
    "msgtype", ["foxglove_msgs/msg/CompressedVideo", "sensor_msgs/msg/CompressedImage"]
)
def test_recording_frames_decode_video(tmp_path: Path, msgtype: str) -> None:
    rec = tmp_path / "video.mcap"
    frames = _write_video(rec, msgtype)
    got = list(RecordingFrames(rec, "/cam"))
    assert len(got) == len(frames)
    for f, src in zip(got, frames, strict=True):
        assert f.image is not None
        assert np.abs(f.image.astype(int) - src.astype(int)).mean() < 6.0


def test_seek_starts_at_the_keyframe_and_yields_from_start(tmp_path: Path) -> None:
    rec = tmp_path / "video.mcap"
    _write_video(rec, "foxglove_msgs/msg/CompressedVideo")
    start = T0 + 7 * STEP  # mid-GOP: keyframes at 0, 5, 10
    with open_recording(rec) as r:
        plain = list(decode_video(r.messages(topics=["/cam"], start_ns=start)))
        seeked = list(read_with_video(r, ["/cam", "/other"], start_ns=start))
    assert all(p.data.error == BEFORE_KEYFRAME for p in plain[:3])
    video = [x for x in seeked if x.msgtype == DECODED_MSGTYPE]
    assert [x.log_time_ns for x in video] == [T0 + i * STEP for i in range(7, 12)]
    assert all(x.data.image is not None for x in video)
    assert min(x.log_time_ns for x in seeked) >= start


def test_extract_writes_video_frames_from_a_mid_gop_start(tmp_path: Path) -> None:
    rec = tmp_path / "video.mcap"
    _write_video(rec, "foxglove_msgs/msg/CompressedVideo")
    result = extract(rec, tmp_path / "out", ExtractConfig(start_s=0.65, frame_format="png"))
    table = pd.read_parquet(tmp_path / "out" / "frames.parquet")
    assert result.skipped == ()
    assert table["ok"].all()
    assert len(table) == 5
    assert set(table["encoding"]) == {"h264"}
    assert (table["width"] == 160).all()
    assert (tmp_path / "out" / table["path"].iloc[0]).is_file()


@pytest.fixture(scope="module")
def twins(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("twins")
    cfg = ReprocessConfig().with_overrides({"output.plots": False})
    runs = {}
    for name, video in (("jpeg", None), ("h264", "h264")):
        rec = root / f"{name}.mcap"
        simulate_drive("highway_curves", 3.0, 3, "mcap", 320, 180, False, rec, video=video)
        runs[name] = root / f"run_{name}"
        result = reprocess(rec, runs[name], cfg)
        assert result.status == "ok", result.skipped
        assert result.frames == 45
    return runs


def test_h264_drive_reprocesses_to_the_lanes_of_its_jpeg_twin(twins: dict[str, Path]) -> None:
    a = pd.read_parquet(twins["jpeg"] / "lanes.parquet")
    b = pd.read_parquet(twins["h264"] / "lanes.parquet")
    fitted_a = np.isfinite(a["curvature"]).sum()
    fitted_b = np.isfinite(b["curvature"]).sum()
    assert fitted_a >= 40
    assert abs(int(fitted_a) - int(fitted_b)) <= 2
    both = a.merge(b, on="frame_index", suffixes=("_j", "_h"))
    width_diff = (both["lane_width_j"] - both["lane_width_h"]).abs()
    assert width_diff.median() < 0.05  # metres
    offset_diff = (both["b_j"] - both["b_h"]).abs()
    assert offset_diff.median() < 0.01


@pytest.mark.parametrize(("fmt", "name"), [("ros1", "v.bag"), ("ros2", "v2"), ("mcap", "v.mcap")])
def test_simulated_h265_video_in_every_format(tmp_path: Path, fmt: str, name: str) -> None:
    out = tmp_path / name
    simulate_drive("highway_curves", 1.0, 1, fmt, 160, 96, False, out, fps=5.0, video="h265")
    with open_recording(out) as rec:
        types = {t.topic: t.msgtype for t in rec.topics()}
    assert "foxglove_msgs/msg/CompressedVideo" in types.values()
    frames = list(RecordingFrames(out))
    assert len(frames) == 5
    assert all(f.image is not None and f.image.shape == (96, 160, 3) for f in frames)


@pytest.mark.parametrize(("encoder", "codec"), [("libsvtav1", "av1"), ("libvpx-vp9", "vp9")])
def test_av1_and_vp9_decode_when_ffmpeg_has_them(encoder: str, codec: str) -> None:
    import fractions

    import av

    if encoder not in av.codecs_available or not decoder_available(codec):
        pytest.skip(f"this FFmpeg build lacks {encoder} or a {codec} decoder")
    ctx = av.CodecContext.create(encoder, "w")
    ctx.width, ctx.height, ctx.pix_fmt = 160, 96, "yuv420p"
    ctx.time_base = fractions.Fraction(1, 10)
    ctx.framerate = 10
    ctx.gop_size = 5
    ctx.max_b_frames = 0
    units: list[bytes] = []
    for i, img in enumerate(_frames(10)):
        frame = av.VideoFrame.from_ndarray(img, format="bgr24")
        frame.pts = i
        units += [bytes(p) for p in ctx.encode(frame)]
    units += [bytes(p) for p in ctx.encode(None)]
    assert is_keyframe(codec, units[0])
    dec = VideoDecoder(codec)
    out = []
    for i, unit in enumerate(units):
        out += dec.feed(i, None, unit)
    out += dec.flush()
    assert len(out) == len(units)
    assert all(o.image is not None for o in out)


def test_extract_cli_takes_absolute_and_iso_times(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from superlane_tools.cli.app import app
    from superlane_tools.recording.times import format_utc

    rec = tmp_path / "video.mcap"
    _write_video(rec, "foxglove_msgs/msg/CompressedVideo")
    runner = CliRunner()
    for start in (str(T0 + 7 * STEP), format_utc(T0 + 7 * STEP), "0.7"):
        out = tmp_path / f"out_{len(start)}"
        result = runner.invoke(app, ["extract", str(rec), "-o", str(out), "--start", start])
        assert result.exit_code == 0, result.output
        table = pd.read_parquet(out / "frames.parquet")
        assert table["log_time_ns"].min() == T0 + 7 * STEP, start
    bad = runner.invoke(app, ["extract", str(rec), "-o", str(tmp_path / "x"), "--start", "soon"])
    assert bad.exit_code == 2
    assert "not a time" in bad.stderr
