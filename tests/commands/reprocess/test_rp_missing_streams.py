"""Reports of drives with missing streams, on real files: exact notes, headline and plots.

Every combination a user meets: a real dashcam clip alone (TuSimple frames made into an MP4 and
``slt convert``-ed), the same clip with the real NMEA log, the real comma2k19 minute (CAN + GNSS
+ IMU, no camera), the real ROS 1 Husky bag (GNSS + IMU only) and a full simulated drive. The
notes are compared whole, so a wrong, missing or contradicting note fails the test.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli import app
from superlane_tools.commands.reprocess import ReprocessResult, reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.simulation.drive import simulate_drive

FAST = ReprocessConfig().with_overrides({"output.example_frames": 1})
CAMERA_NOTE = "camera: CameraInfo /camera/camera_info + extrinsics from MCAP metadata slt_camera"
NO_CAN = "no CAN stream: no CAN speed, yaw rate or Mobileye lane messages"
NO_YAW = "no yaw rate: no CAN yaw-rate signal, no IMU"


def _without_self_check(notes: tuple[str, ...]) -> tuple[str, ...]:
    """The notes less the segmentation self-check's lines (tests/drive/test_drive_selfcheck.py)."""
    checked = [n for n in notes if "self-check" in n]
    assert checked, notes  # auto ran it
    return tuple(n for n in notes if "self-check" not in n)


@pytest.fixture(scope="module")
def dashcam(realdata: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Six real TuSimple frames as a 10 Hz MP4 (OpenCV's MPEG-4), as a dashcam would save."""
    import cv2

    frames = sorted((realdata / "tusimple" / "frames").glob("0*.png"))
    assert len(frames) >= 6
    mp4 = tmp_path_factory.mktemp("dashcam") / "dash.mp4"
    writer = cv2.VideoWriter(str(mp4), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (1280, 720))
    for path in frames[:6]:
        writer.write(cv2.resize(cv2.imread(str(path)), (1280, 720)))
    writer.release()
    return mp4


def _convert(tmp_path: Path, *inputs: Path) -> Path:
    out = tmp_path / "drive.mcap"
    args = ["convert", *map(str, inputs), "-o", str(out), "--camera", "tusimple"]
    # the NMEA log was recorded on 2020-04-20 from 09:25:42 UTC: the clip starts inside it
    result = CliRunner().invoke(app, [*args, "--video-start", "2020-04-20T09:25:50Z"])
    assert result.exit_code == 0, result.output
    return out


def _availability_methods(out: Path) -> list[str]:
    """Methods of the report's availability table (the plot is drawn from the same methods)."""
    report = (out / "report.md").read_text(encoding="utf-8")
    section = report.split("## Availability")[1].split("\n## ")[0]
    rows = [line for line in section.splitlines() if line.startswith("| ")][1:]
    return [row.split("|")[1].strip() for row in rows]


def _headline(out: Path) -> str:
    return (out / "report.md").read_text(encoding="utf-8").split("## Headline\n\n")[1]


def _headline_table(out: Path) -> str:
    """The headline's table: its rows, without the sentences above it."""
    section = _headline(out).split("\n## ")[0]
    return "\n".join(line for line in section.splitlines() if line.startswith("| "))


@pytest.mark.realdata
def test_camera_only_clip(dashcam: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = reprocess(_convert(tmp_path, dashcam), out, FAST)
    assert _without_self_check(result.notes) == (
        CAMERA_NOTE,
        NO_CAN,
        "speed unknown (no CAN stream, no GNSS stream): availability by corridor length "
        "unknown on every frame",
        "no curvature ground truth: no GNSS stream",
        f"no yaw-rate / speed curvature reference: {NO_YAW}; no speed",
        "lane tracker: not run (no distance travelled: no speed, no GNSS fixes); curvature "
        "from the untracked fit",
    )
    assert _headline(out).startswith(
        "**Inputs:** camera (6 frames), no CAN, no GNSS. **Measured:** corridor widths and "
        "lengths of SUPER, the corridor network, Hough. **Not measured:** availability: unknown "
        "on every frame, no speed (no CAN stream, no GNSS stream); curvature errors: no truth "
        "(no GNSS stream); Mobileye: no CAN stream.\n"
    )
    assert (
        "**Availability:** SUPER unknown on every frame (no speed to judge the corridor "
        "length); Corridor net unknown on every frame (no speed to judge the corridor length); "
        "Hough 0 % available (5 of 6 frames unknown: no speed): 1 of 6 frames no ego line pair "
        "found by Hough.\n"
    ) in _headline(out)
    headline = _headline_table(out)
    assert "| SUPER | no truth | unknown (no speed) | unknown (no speed) |" in headline
    assert "Mobileye" not in headline  # did not run: no row, not "0.0%"
    assert "| Hough | no truth | 0.0% (5 of 6 frames unknown) |" in headline  # 1 known miss
    assert _availability_methods(out) == ["super", "corridor_net", "hough"]
    frames = pd.read_parquet(out / "availability_frames.parquet")
    super_frames = frames[frames["method"] == "super"]
    assert not super_frames["known"].any()  # unknown, not unavailable
    assert (out / "plots" / "availability_timeline.png").is_file()


@pytest.mark.realdata
def test_camera_with_gnss_without_can(realdata: Path, dashcam: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = reprocess(_convert(tmp_path, dashcam, realdata / "gnss" / "nmea.log"), out, FAST)
    assert _without_self_check(result.notes) == (
        CAMERA_NOTE,
        NO_CAN,
        "speed: estimated from the GNSS fixes (no CAN stream)",
        "no curvature ground truth: all 120 GNSS fixes while standing or crawling (below 2 m/s)",
        f"no yaw-rate / speed curvature reference: {NO_YAW}",
        "lane tracker: 5 of 6 frame fits used, 1 rejected by the innovation gate; distance "
        "travelled from the GNSS speed",
    )
    assert _headline(out).startswith(
        "**Inputs:** camera (6 frames), no CAN, GNSS (RTK). **Measured:** corridor widths and "
        "lengths of SUPER, the corridor network, Hough; availability (speed from GNSS). "
        "**Not measured:** curvature errors: no truth (all 120 GNSS fixes while standing or "
        "crawling (below 2 m/s)); Mobileye: no CAN stream.\n"
    )
    assert _availability_methods(out) == ["super", "corridor_net", "hough"]


@pytest.mark.slow
@pytest.mark.realdata
def test_comma2k19_can_and_gnss_without_camera(
    realdata: Path, comma2k19: Path, tmp_path: Path
) -> None:
    dbc = realdata / "dbc" / "opendbc"
    cfg = ReprocessConfig().with_overrides(
        {  # as tests/commands/reprocess/test_rp_no_camera.py decodes the minute
            "can.dbcs": [
                f"can0={dbc / 'toyota_generator__toyota_2017.dbc'}",
                f"can1={dbc / 'toyota_adas.dbc'}",
            ],
            "can.speed_signal": "SPEED",
            "can.yaw_rate_signal": "",
            "rtk.imu_yaw_axis": "-z",
        }
    )
    out = tmp_path / "run"
    result = reprocess(comma2k19, out, cfg)
    notes = list(result.notes)
    assert notes.pop(1).startswith("DBC coverage: 60 of 130 CAN ids matched; unknown ids: 0xBA")
    assert notes == [
        "no camera stream: SUPER, the corridor network and Hough not computed; the signals "
        "are evaluated on a 15 Hz grid of 900 instants",
        "speed: CAN signal 'SPEED'",
        "truth degraded: not RTK: plain GNSS fixes only (no RTK fixed fix)",
        "truth: 854 of 900 instants; no sample below 2.0 m/s (0 fixes while standing or "
        "crawling); fixes decimated to >= 0.25 m steps; noise floor unknown 1/m",
        "yaw-rate / speed reference: IMU gyro about -z, speed from CAN; gyro bias "
        "0.00e+00 rad/s (none)",
        "no Mobileye lane messages on CAN: no Mobileye comparison",
    ]
    assert _headline(out).startswith(
        "**Inputs:** no camera stream, CAN, GNSS (plain, not RTK), IMU. **Measured:** "
        "curvature errors against the truth at 854 instants. **Not measured:** Mobileye: no "
        "Mobileye lane messages on CAN; SUPER, the corridor network and Hough: no camera "
        "stream.\n"
    )
    assert _availability_methods(out) == []  # no method ran: no availability table, no plot
    assert not (out / "plots" / "availability_timeline.png").exists()


@pytest.mark.slow
@pytest.mark.realdata
def test_husky_bag_gnss_and_imu_only(realdata: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    bag = realdata / "bags" / "ros1_robot_localization" / "test1.bag"
    result = reprocess(bag, out, ReprocessConfig())
    assert result.notes == (
        "no camera stream: SUPER, the corridor network and Hough not computed; the signals "
        "are evaluated on a 15 Hz grid of 5930 instants",
        NO_CAN,
        "speed unknown (no CAN stream, GNSS fixes too sparse for a speed at the evaluation "
        "instants)",
        "no curvature ground truth: none of the 989 GNSS fixes gives a truth at an "
        "evaluation instant",
        "no yaw-rate / speed curvature reference: no speed",
    )
    assert _headline(out).startswith(
        "**Inputs:** no camera stream, no CAN, GNSS (plain, not RTK), IMU. **Measured:** "
        "nothing. **Not measured:** curvature errors: no truth (none of the 989 GNSS fixes "
        "gives a truth at an evaluation instant); "
        "Mobileye: no CAN stream; SUPER, the corridor network and Hough: no camera stream.\n"
    )
    assert _availability_methods(out) == []


@pytest.mark.slow
def test_full_simulated_drive(tmp_path: Path) -> None:
    drive = tmp_path / "sim.mcap"
    simulate_drive("highway_curves", 4.0, 3, "mcap", 320, 180, False, drive)
    out = tmp_path / "run"
    result: ReprocessResult = reprocess(drive, out, FAST)
    checked = _without_self_check(result.notes)
    notes = [n for n in checked if not n.startswith("Mobileye latency")]
    assert notes == [
        CAMERA_NOTE,
        "DBC coverage: 6 of 6 CAN ids matched",
        "speed: CAN signal 'VehicleSpeed'",
        "truth: 42 of 60 instants; no sample below 2.0 m/s (0 fixes while standing or "
        "crawling); fixes decimated to >= 0.25 m steps; noise floor 7.23e-05 1/m",
        "yaw-rate / speed reference: CAN yaw rate, speed from CAN; gyro bias 0.00e+00 rad/s (none)",
        "lane tracker: 58 of 60 frame fits used, 2 rejected by the innovation gate; distance "
        "travelled from the CAN speed",
    ]
    latency = [n for n in result.notes if n.startswith("Mobileye latency")]
    assert len(latency) == 1
    assert "NOT resolved" in latency[0]  # 4 s without a repeated lateral event
    assert _headline(out).startswith(
        "**Inputs:** camera (60 frames), CAN, GNSS (RTK). **Measured:** corridor widths and "
        "lengths of SUPER, the corridor network, Hough; availability (speed from CAN); "
        "curvature errors against the truth at 42 instants; the Mobileye comparison.\n"
    )
    assert _availability_methods(out) == ["super", "corridor_net", "hough", "mobileye"]
