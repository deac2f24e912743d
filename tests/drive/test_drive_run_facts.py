"""The report's header and camera facts come from the shipped model cards and the profile files."""

from __future__ import annotations

import math
from datetime import UTC, datetime
from pathlib import Path

from superlane_tools.camera import camera_to_yaml, load_camera
from superlane_tools.drive.run_facts import camera_facts, model_licences, run_header
from superlane_tools.reporting.provenance import Provenance


def test_licences_come_from_the_model_cards() -> None:
    lines = model_licences({"onnx:super_seg_v5": "x", "onnx:super_seg_v2": "y", "mine": "z"})
    assert lines[0].startswith("super_seg_v5: NON-COMMERCIAL USE ONLY: CamVid (CC BY-NC 4.0)")
    assert "NON-COMMERCIAL" not in lines[1]  # simulator data only
    assert lines[1] == "super_seg_v2: not stated in its card"
    assert lines[2] == "mine: unknown (not a bundled model: see its card)"


def test_header_has_version_command_date_and_licences() -> None:
    prov = Provenance(command="slt reprocess a.mcap", models={"onnx:ego_corridor_v3": "s"})
    when = datetime(2026, 12, 3, 19, 0, 0, tzinfo=UTC)
    header = run_header(prov, when)
    assert header[:3] == (
        f"- tool: superlane-tools {prov.tool_version}",
        "- command: `slt reprocess a.mcap`",
        "- date: 2026-12-03 19:00:00 UTC",
    )
    assert header[3].startswith("- model ego_corridor_v3: training data: TuSimple")
    assert run_header(Provenance(command="c"), when)[3] == "- models: none (no network ran)"


def test_camera_facts_read_the_estimate_block(tmp_path: Path) -> None:
    recording = tmp_path / "drive.mcap"
    text = camera_to_yaml(load_camera("sim_default")) + (
        "estimate:\n  lane_width_m: 3.7\n  roll_deg: 2.06\n  frames_used: 12\n"
        "  roll_method: lane centred on average (camera on the vehicle centre line)\n"
        "  intrinsics: horizontal field of view 60 deg ASSUMED (typical dashcam)\n"
    )
    (tmp_path / "drive.camera.yaml").write_text(text, encoding="utf-8")
    beside = camera_facts(
        "auto", "camera profile drive.camera.yaml beside the recording", recording
    )
    assert beside.profile == "drive.camera.yaml"
    assert beside.lane_width_m == 3.7
    assert beside.intrinsics_assumed
    assert (beside.roll_deg, beside.roll_frames) == (2.06, 12)
    given = camera_facts(str(tmp_path / "drive.camera.yaml"), "camera profile x", recording)
    assert given == beside
    plain = tmp_path / "plain.yaml"
    plain.write_text(camera_to_yaml(load_camera("sim_default")), encoding="utf-8")
    assert math.isnan(camera_facts(str(plain), "", recording).lane_width_m)
    assert camera_facts("tusimple", "camera profile tusimple", recording).profile == ""
