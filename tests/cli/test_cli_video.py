"""A dashcam video in one command: ``slt info``, ``slt camera estimate`` and ``slt reprocess``
read an MP4 directly, on a real short video made from the shared Udacity stills."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli import app
from superlane_tools.recording import open_recording
from superlane_tools.recording.calibration import camera_sidecar, camera_sidecars

runner = CliRunner()
UDACITY = "udacity/advanced_lane_lines/test_images"


def _write_mp4(stills: list[Path], out: Path, size: tuple[int, int], repeat: int) -> Path:
    """Encode the stills (each ``repeat`` times, 5 frames/s) into an H.264 MP4 with PyAV."""
    import av
    import cv2

    with av.open(str(out), "w") as container:
        stream = container.add_stream("libx264", rate=5)
        stream.width, stream.height = size
        stream.pix_fmt = "yuv420p"
        for still in stills:
            image = cv2.resize(cv2.imread(str(still)), size)
            for _ in range(repeat):
                frame = av.VideoFrame.from_ndarray(image, format="bgr24")
                for packet in stream.encode(frame):
                    container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return out


@pytest.fixture
def clip(realdata: Path, tmp_path: Path) -> Path:
    """An 8-still, 16-frame 640x360 MP4 of the real Udacity highway frames (3.2 s)."""
    stills = sorted((realdata / UDACITY).glob("*.jpg"))
    assert len(stills) == 8
    folder = tmp_path / "videos"
    folder.mkdir()
    return _write_mp4(stills, folder / "clip.mp4", (640, 360), 2)


def test_a_video_opens_as_a_recording(clip: Path) -> None:
    with open_recording(clip) as rec:
        (topic,) = rec.topics()
        assert topic.topic == "/camera/video"
        assert topic.msgtype == "foxglove_msgs/msg/CompressedVideo"
        assert sum(1 for _ in rec.messages()) == 16
        assert rec.path == clip  # not the temporary MCAP: sidecars and names follow the video
    res = runner.invoke(app, ["info", str(clip)])
    assert res.exit_code == 0, res.output
    assert "[video]" in res.stdout
    assert "/camera/video" in res.stdout
    assert sorted(p.name for p in clip.parent.iterdir()) == ["clip.mp4"]  # nothing beside it


def test_reprocess_reads_a_video_with_the_profile_beside_it(clip: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    args = ["reprocess", str(clip), "-o", str(out), "--backend", "classical", "--no-plots"]
    missing = runner.invoke(app, args)
    assert missing.exit_code == 2, missing.output
    assert f"slt camera estimate {clip.name}" in missing.stderr  # the one command to run
    assert "clip.camera.yaml" in missing.stderr
    assert not out.exists()
    # the profile `slt camera estimate clip.mp4 -o clip.mp4.camera.yaml` would write
    shown = runner.invoke(app, ["camera", "show", "tusimple"])
    (clip.parent / "clip.mp4.camera.yaml").write_text(shown.stdout)
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "camera profile clip.mp4.camera.yaml beside the recording" in res.stderr
    lines = res.stdout.splitlines()
    assert lines[-1].startswith(f"report: {out / 'report.html'} -- ")
    assert "SUPER" in lines[-1]
    assert (out / "report.html").is_file()


def test_both_sidecar_names_are_read(tmp_path: Path) -> None:
    rec = tmp_path / "dash.mcap"
    full, stem = camera_sidecars(rec)
    assert (full.name, stem.name) == ("dash.mcap.camera.yaml", "dash.camera.yaml")
    assert camera_sidecar(rec) == stem  # the default name `slt camera estimate` writes
    full.write_text("x")
    assert camera_sidecar(rec) == full
    bag = tmp_path / "drive"  # a ROS 2 bag folder
    assert camera_sidecars(bag) == (tmp_path / "drive.camera.yaml",)


def test_camera_estimate_writes_the_profile_auto_reads(clip: Path) -> None:
    res = runner.invoke(app, ["camera", "estimate", str(clip), "--frames", "8"])
    assert res.exit_code == 0, res.output
    profile = clip.parent / "clip.camera.yaml"
    assert profile.is_file()
    assert f"wrote {profile}" in res.stderr
    notes = res.stderr
    assert "ASSUMED lane width" in notes
    assert "3.7 m" in notes
    assert "ASSUMED field of view: 60 deg" in notes
    assert "UNRELIABLE roll" in notes
    assert "3.0 s drive" in notes
    text = profile.read_text()
    assert "assumptions:" in text
    assert "UNRELIABLE roll" in text
    again = runner.invoke(app, ["camera", "estimate", str(clip), "--frames", "8"])
    assert again.exit_code == 2
    assert "camera estimate: " in again.stderr
    assert "--overwrite" in again.stderr
    assert profile.read_text() == text  # refused before any work: nothing written


def test_a_video_that_is_not_one_names_slt_convert(tmp_path: Path) -> None:
    junk = tmp_path / "clip.mp4"
    junk.write_bytes(b"not a video at all, just text")
    res = runner.invoke(app, ["info", str(junk)])
    assert res.exit_code == 1
    assert "its content is not mp4" in res.stderr
    other = tmp_path / "track.gpx"
    other.write_text("<gpx></gpx>")
    res = runner.invoke(app, ["reprocess", str(other), "-o", str(tmp_path / "r")])
    assert res.exit_code == 1
    assert "slt convert" in res.stderr
