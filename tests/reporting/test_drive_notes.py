"""The notes, inputs line and gaps of a drive come from one DriveFacts and never disagree."""

from __future__ import annotations

import itertools

import pandas as pd
import pytest

from superlane_tools.reporting.drive_facts import (
    SPEED_CAN,
    SPEED_GNSS,
    TRAVELLED_SPEED,
    TRAVELLED_TRACK,
    TRUTH_RTK,
    YAW_CAN,
    YAW_IMU,
    DriveFacts,
)
from superlane_tools.reporting.drive_notes import (
    availability_gaps,
    curvature_gaps,
    drive_notes,
    inputs_line,
    timing_line,
)
from superlane_tools.reporting.headline import headline_table


def _facts(camera: bool, can: bool, gnss: bool, imu: bool, mobileye: bool) -> DriveFacts:
    """Facts as drive_tables derives them from which streams a drive has."""
    speed = SPEED_CAN if can else (SPEED_GNSS if gnss else "")
    yaw = YAW_CAN if can else (YAW_IMU if imu else "")
    travelled = TRAVELLED_SPEED if speed else (TRAVELLED_TRACK if gnss else "")
    return DriveFacts(
        n_instants=100,
        camera=camera,
        grid_hz=0.0 if camera else 15.0,
        can=can,
        can_coverage="DBC coverage: 6 of 6 CAN ids matched" if can else "",
        speed_signal="VehicleSpeed",
        speed=speed,
        gnss=gnss,
        n_fixes=50 if gnss else 0,
        truth=TRUTH_RTK if gnss else "",
        truth_instants=80 if gnss else 0,
        min_speed_mps=2.0,
        yaw=yaw,
        imu_axis="z",
        dynamics=bool(yaw and speed),
        gyro_bias_rps=0.0,
        gyro_bias_source="none",
        mobileye=can and mobileye,
        tracker=camera and bool(travelled),
        travelled=travelled if camera else "",
        tracker_used=90 if camera and travelled else 0,
    )


COMBINATIONS = [
    _facts(*flags)
    for flags in itertools.product((True, False), repeat=5)
    if not (flags[4] and not flags[1])  # Mobileye only on CAN
]


@pytest.mark.parametrize("facts", COMBINATIONS)
def test_notes_never_contradict(facts: DriveFacts) -> None:
    text = " | ".join([*drive_notes(facts), inputs_line(facts), *availability_gaps(facts)])
    text += " | ".join(curvature_gaps(facts))
    if facts.speed:
        assert "speed unknown" not in text
        assert "no speed" not in text
    else:
        assert "speed: " not in text
        assert "speed from" not in text
    if not facts.gnss:
        assert "GNSS track" not in text
        assert "GNSS speed" not in text
        assert "RTK track" not in text
        assert "from the GNSS" not in text
    if not facts.mobileye:
        assert "Mobileye latency" not in text
        assert "the Mobileye comparison" not in text
        assert "Mobileye evaluated" not in text
    if not facts.camera:
        assert "lane tracker" not in text
        assert "frame fits" not in text
    if not facts.truth_instants:
        assert not [n for n in drive_notes(facts) if n.startswith(("truth:", "RTK:"))]
    assert "NOT EVALUATED: Mobileye" in text or facts.mobileye


def test_camera_only_notes_exact() -> None:
    facts = _facts(camera=True, can=False, gnss=False, imu=False, mobileye=False)
    assert drive_notes(facts) == [
        "no CAN stream: no CAN speed, yaw rate or Mobileye lane messages",
        "speed unknown (no CAN stream, no GNSS stream): availability by corridor length "
        "unknown on every frame",
        "no curvature ground truth: no GNSS stream",
        "no yaw-rate / speed curvature reference: no yaw rate: no CAN yaw-rate signal, no IMU; "
        "no speed",
        "lane tracker: not run (no distance travelled: no speed, no GNSS fixes); curvature "
        "from the untracked fit",
    ]


def test_timing_line_says_stage_times_are_thread_sums() -> None:
    line = timing_line(
        {"segmentation": 11.8, "cpu_segmentation": 1.7, "pass_wall": 9.0, "total": 9.5}
    )
    assert line == (
        "wall: pass 9.0 s; per stage, summed over the worker threads (may exceed the wall "
        "time): segmentation 11.8 s; per stage thread CPU: segmentation 1.7 s"
    )
    assert timing_line({"total": 6.1}) == ""  # nothing to say: no empty line


def test_headline_keeps_unknown_apart_and_leaves_out_methods_not_run() -> None:
    facts = _facts(camera=True, can=False, gnss=False, imu=False, mobileye=False)
    seqs = pd.DataFrame(
        {
            "method": ["super", "corridor_net", "hough", "mobileye"],
            "n_frames": [6, 6, 6, 6],
            "n_available": [0, 0, 0, 0],
            "n_unknown": [6, 6, 5, 0],
            "available": pd.array([None, None, None, False], dtype="boolean"),
            "method_available": [True, True, True, False],
        }
    )
    table = headline_table(pd.DataFrame(), seqs, float("nan"), facts)
    assert table.to_dict("records") == [
        {
            "method": "SUPER",
            "curvature RMSE (1/m)": "no truth",
            "frames available": "unknown (no speed)",
            "sequences available": "unknown (no speed)",
        },
        {
            "method": "Corridor net",
            "curvature RMSE (1/m)": "no truth",
            "frames available": "unknown (no speed)",
            "sequences available": "unknown (no speed)",
        },
        {
            "method": "Hough",
            "curvature RMSE (1/m)": "no truth",
            "frames available": "0.0% (5 of 6 frames unknown)",
            "sequences available": "unknown (decided by unknown frames)",
        },
    ]


def test_an_estimated_camera_is_labelled_and_its_widths_are_not_measured() -> None:
    from dataclasses import replace

    from superlane_tools.reporting.drive_facts import CameraFacts
    from superlane_tools.reporting.drive_notes import assumption_notes

    plain = _facts(camera=True, can=True, gnss=True, imu=False, mobileye=False)
    assert assumption_notes(plain) == []
    cam = CameraFacts("dash.camera.yaml", 3.7, "hfov 60 deg ASSUMED", True, 2.06, 9)
    facts = replace(plain, camera_facts=cam)
    assert facts.widths_circular
    notes = assumption_notes(facts)
    assert [n.split(":")[0] for n in notes] == [
        "ASSUMED, not measured",
        "ASSUMED, not measured",
        "ESTIMATED under an assumption",
    ]
    assert "lane width 3.7 m. The camera height (dash.camera.yaml) was scaled" in notes[0]
    assert "roll 2.06 degrees from 9 frames" in notes[2]
    assert notes == [n for n in drive_notes(facts) if n.startswith(("ASSUMED", "ESTIMATED"))]
    line = inputs_line(facts)
    assert "corridor widths and lengths" not in line
    assert "**Not measured:** corridor widths: circular" in line
