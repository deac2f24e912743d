"""The simulator accuracy pipeline on a tiny drive: simulate, fit, compare with ground truth."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import pytest
import yaml

from superlane_tools.lanes.class_map import parse_classes

SCRIPT = Path(__file__).resolve().parents[2] / "pipelines" / "sim_lane_accuracy.py"


def _pipeline() -> ModuleType:
    spec = importlib.util.spec_from_file_location("sim_lane_accuracy", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("sim_lane_accuracy", module)
    spec.loader.exec_module(module)
    return module


def test_classes_yaml_maps_markings_and_road() -> None:
    data = _pipeline().classes_yaml()
    classes = parse_classes(yaml.safe_load(yaml.safe_dump(data)))
    assert data["road"]
    assert "dividing_white_dashed" in data
    assert classes.lane_ids
    assert set(data["road"]) <= set(classes.road_ids)


@pytest.mark.slow
def test_pipeline_on_a_short_highway_drive(tmp_path: Path) -> None:
    report = tmp_path / "acc.md"
    out = tmp_path / "acc.json"
    code = _pipeline().main(
        [
            "--work",
            str(tmp_path / "work"),
            "--duration",
            "0.6",
            "--fps",
            "5",
            "--width",
            "480",
            "--height",
            "270",
            "--scenarios",
            "highway_straight",
            "--report",
            str(report),
            "--json",
            str(out),
        ]
    )
    assert code == 0
    result = json.loads(out.read_text())["highway_straight"]
    assert result["frames"] == 3
    assert result["fitted"] == 3
    assert result["heading_rad"]["rmse"] < 0.01
    assert result["curvature_1pm"]["rmse"] < 5e-4
    assert result["slope"]["rmse"] < 0.01
    assert result["ego_left_m"]["found"] == 3
    assert result["ego_left_m"]["rmse"] < 0.2
    assert result["ego_right_m"]["found"] == 3
    assert result["ego_right_m"]["rmse"] < 0.2
    text = report.read_text()
    assert "| highway_straight | 3/3 |" in text
    assert "slt simulate --scenario highway_straight" in text
    assert "slt lanes fit" in text
