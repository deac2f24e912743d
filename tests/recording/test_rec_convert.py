"""`slt convert`: videos, GNSS/CAN/CSV logs into MCAP; the dashcam-only flow end to end."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.errors import UsageError
from superlane_tools.recording import open_recording
from superlane_tools.recording.convert import METADATA_NAME
from superlane_tools.recording.times import format_utc, parse_time
from superlane_tools.recording.video import decode_video

runner = CliRunner()
START = "2016-12-01T10:00:00Z"
START_NS = 1_480_586_400_000_000_000


def _mp4(path: Path, images: list[np.ndarray], fps: int = 2, bframes: bool = False) -> Path:
    """Encode BGR images into an MP4 with PyAV (libx264), as a dashcam would."""
    import av

    height, width = images[0].shape[:2]
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=fps)
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.codec_context.time_base = Fraction(1, fps)
        stream.codec_context.options = {"bf": "3" if bframes else "0", "crf": "18"}
        container.metadata["creation_time"] = START
        for img in images:
            frame = av.VideoFrame.from_ndarray(img, format="bgr24")
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)
    return path


def _metadata(path: Path) -> dict[str, str]:
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        for record in make_reader(handle).iter_metadata():
            if record.name == METADATA_NAME:
                return dict(record.metadata)
    return {}


def test_parse_time_forms() -> None:
    assert parse_time("12.5") == (12_500_000_000, False)
    assert parse_time("3s") == (3_000_000_000, False)
    assert parse_time(START) == (START_NS, True)
    assert parse_time("2016-12-01 11:00:00+01:00") == (START_NS, True)
    assert parse_time(str(START_NS)) == (START_NS, True)
    assert parse_time("42ns") == (42, True)
    assert parse_time("1.5").resolve(100) == 1_500_000_100
    assert format_utc(START_NS + 5) == "2016-12-01T10:00:00.000000005Z"
    with pytest.raises(UsageError, match="not a time"):
        parse_time("yesterday")


def _frames(n: int) -> list[np.ndarray]:
    yy, xx = np.mgrid[0:96, 0:160]
    return [
        np.dstack([(xx + 8 * i) % 256, yy * 2, np.full_like(xx, 60)]).astype(np.uint8)
        for i in range(n)
    ]


@pytest.mark.parametrize("bframes", [False, True])
def test_video_converts_with_container_times(tmp_path: Path, bframes: bool) -> None:
    mp4 = _mp4(tmp_path / "dash.mp4", _frames(10), fps=5, bframes=bframes)
    out = tmp_path / "dash.mcap"
    result = runner.invoke(app, ["convert", str(mp4), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert ("re-encoded" in result.stderr) == bframes
    with open_recording(out) as rec:
        frames = [m for m in decode_video(rec.messages()) if m.topic == "/camera/video"]
    assert [m.log_time_ns for m in frames] == [START_NS + i * 200_000_000 for i in range(10)]
    assert all(m.data.image is not None for m in frames)
    meta = _metadata(out)
    assert meta["dash.mp4.start"].startswith("2016-12-01T10:00:00.000000000Z")
    assert meta["clock"].startswith("shared clock")


def test_video_with_gnss_can_and_csv_aligned_by_offsets(realdata: Path, tmp_path: Path) -> None:
    mp4 = _mp4(tmp_path / "dash.mp4", _frames(4), fps=2)
    csv = tmp_path / "signals.csv"
    pd.DataFrame({"time": [0.0, 0.5, 1.0], "speed_mps": [10.0, 10.5, 11.0]}).to_csv(
        csv, index=False
    )
    nmea = realdata / "gnss" / "nmea.log"
    can = realdata / "can_logs" / "ford_fusion" / "car_50km.log"
    out = tmp_path / "all.mcap"
    args = ["convert", str(mp4), str(nmea), str(can), str(csv), "-o", str(out)]
    args += ["--video-start", str(START_NS)]
    args += ["--offset", f"signals.csv={START_NS / 1e9}", "--offset", "car_50km.log=-1.0"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    with open_recording(out) as rec:
        topics = {t.topic: t for t in rec.topics()}
        assert topics["/camera/video"].msgtype == "foxglove_msgs/msg/CompressedVideo"
        assert topics["/gnss/fix"].msgtype == "sensor_msgs/msg/NavSatFix"
        assert topics["/gnss/fix"].message_count >= 100
        assert topics["/signals/speed_mps"].message_count == 3
        can_topic = next(t for t in topics if t.startswith("/can/"))
        assert topics[can_topic].msgtype == "can_msgs/msg/Frame"
        speed = list(rec.messages(topics=["/signals/speed_mps"]))
        assert speed[1].log_time_ns == START_NS + 500_000_000
        assert speed[1].data.data == pytest.approx(10.5)
    meta = _metadata(out)
    assert meta["car_50km.log.offset_ns"] == "-1000000000"
    assert meta["clock"] == "each input's clock plus its --offset"


def test_logs_alone_and_gpx(realdata: Path, tmp_path: Path) -> None:
    import gpxpy.gpx

    gpx = gpxpy.gpx.GPX()
    track = gpxpy.gpx.GPXTrack()
    seg = gpxpy.gpx.GPXTrackSegment()
    for i in range(5):
        from datetime import UTC, datetime, timedelta

        when = datetime(2020, 5, 1, 12, 0, tzinfo=UTC) + timedelta(seconds=i)
        seg.points.append(
            gpxpy.gpx.GPXTrackPoint(48.1 + i * 1e-5, 11.5, elevation=520.0, time=when)
        )
    track.segments.append(seg)
    gpx.tracks.append(track)
    gpx_path = tmp_path / "track.gpx"
    gpx_path.write_text(gpx.to_xml(), encoding="utf-8")
    for src, topic, count in (
        (gpx_path, "/gnss/fix", 5),
        (realdata / "gnss" / "nmea.log", "/gnss/fix", None),
        (realdata / "can_logs" / "ford_fusion" / "nothing.log", None, None),
    ):
        out = tmp_path / f"{src.stem}.mcap"
        result = runner.invoke(app, ["convert", str(src), "-o", str(out)])
        assert result.exit_code == 0, result.output
        with open_recording(out) as rec:
            names = [t.topic for t in rec.topics()]
            if topic is not None:
                assert names == [topic]
                first = next(iter(rec.messages()))
                assert 40 < first.data.latitude < 50 or 30 < first.data.latitude < 40
            else:
                assert all(n.startswith("/can/") for n in names)
            if count is not None:
                assert sum(1 for _ in rec.messages()) == count


def test_bad_inputs_are_one_line_errors(tmp_path: Path) -> None:
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"\x00\x01garbage")
    out = tmp_path / "o.mcap"
    result = runner.invoke(app, ["convert", str(junk), "-o", str(out)])
    assert result.exit_code == 1
    assert result.stderr.startswith("slt: error: junk.bin: cannot tell what this file is")
    bad = runner.invoke(app, ["convert", str(junk), "-o", str(out), "--offset", "other=1"])
    assert bad.exit_code == 2
    assert "not one of the INPUT files" in bad.stderr
    assert not out.exists()


@pytest.mark.slow
def test_udacity_dashcam_frames_convert_calibrate_and_reprocess(
    realdata: Path, tmp_path: Path
) -> None:
    """The 8 real Udacity frames as a dashcam MP4, its chessboard profile, then reprocess."""
    import cv2

    root = realdata / "udacity" / "advanced_lane_lines"
    images = [cv2.imread(str(p)) for p in sorted((root / "test_images").glob("*.jpg"))]
    assert len(images) == 8
    mp4 = _mp4(tmp_path / "udacity.mp4", images, fps=2)
    rec = tmp_path / "udacity.mcap"
    conv = runner.invoke(app, ["convert", str(mp4), "-o", str(rec)])
    assert conv.exit_code == 0, conv.output
    profile = tmp_path / "udacity.yaml"
    cal = runner.invoke(app, ["camera", "calibrate", str(root / "camera_cal"), "-o", str(profile)])
    assert cal.exit_code == 3, cal.output  # a profile; 5 of the 20 photos were not usable
    run = tmp_path / "run"
    result = runner.invoke(app, ["reprocess", str(rec), "-o", str(run), "--camera", str(profile)])
    assert result.exit_code in (0, 3), result.output
    lanes = pd.read_parquet(run / "lanes.parquet")
    assert len(lanes) == 8
    fitted = lanes[np.isfinite(lanes["curvature"])]
    assert len(fitted) >= 6
    widths = fitted["lane_width"].dropna()
    assert ((widths > 2.3) & (widths < 4.8)).mean() >= 0.75
    assert list((run / "plots").glob("example_*.png"))


def test_camera_auto_uses_a_profile_beside_the_recording(tmp_path: Path) -> None:
    from superlane_tools.camera import camera_to_yaml, load_camera

    mp4 = _mp4(tmp_path / "dash.mp4", _frames(3), fps=2)
    rec = tmp_path / "dash.mcap"
    assert runner.invoke(app, ["convert", str(mp4), "-o", str(rec)]).exit_code == 0
    run = ["reprocess", str(rec), "-o", str(tmp_path / "run"), "--camera", "auto", "--no-plots"]
    missing = runner.invoke(app, run)
    assert missing.exit_code == 2
    assert "slt camera calibrate" in missing.stderr
    assert "slt camera estimate" in missing.stderr
    assert "dash.camera.yaml" in missing.stderr
    profile = load_camera("sim_default").resized(160, 96)
    (tmp_path / "dash.camera.yaml").write_text(camera_to_yaml(profile), encoding="utf-8")
    found = runner.invoke(app, run)
    assert found.exit_code in (0, 3), found.output
    assert "dash.camera.yaml beside the recording" in found.output


def test_convert_with_camera_lets_auto_find_camera_info_and_extrinsics(tmp_path: Path) -> None:
    mp4 = _mp4(tmp_path / "dash.mp4", _frames(3), fps=2)
    rec = tmp_path / "dash.mcap"
    conv = runner.invoke(app, ["convert", str(mp4), "-o", str(rec), "--camera", "sim_default"])
    assert conv.exit_code == 0, conv.output
    with open_recording(rec) as r:
        infos = list(r.messages(topics=["/camera/camera_info"]))
    assert len(infos) == 3
    assert (infos[0].data.width, infos[0].data.height) == (160, 96)  # scaled to the video
    assert _metadata_named(rec, "slt_camera")["height_m"] == "1.5"
    run = ["reprocess", str(rec), "-o", str(tmp_path / "run"), "--camera", "auto", "--no-plots"]
    result = runner.invoke(app, run)
    assert result.exit_code in (0, 3), result.output
    assert "extrinsics from MCAP metadata slt_camera" in result.output


def _metadata_named(path: Path, name: str) -> dict[str, str]:
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        for record in make_reader(handle).iter_metadata():
            if record.name == name:
                return dict(record.metadata)
    return {}
