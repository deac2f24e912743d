"""`pipelines/train_models.py --quick` runs end to end: dataset, training, evaluation, cards."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from superlane_tools.scene.model_card import load_card

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_quick_pipeline_runs_end_to_end(tmp_path: Path) -> None:
    out = tmp_path / "models"
    cmd = [
        sys.executable,
        str(REPO / "pipelines" / "train_models.py"),
        "--quick",
        "--work",
        str(tmp_path / "work"),
        "--out",
        str(out),
        "--json",
        str(tmp_path / "r.json"),
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    assert "slt simulate dataset" in results["commands"]["train_dataset_0"]
    assert "--seed 99" in results["commands"]["test_dataset"]
    seg = load_card(out / "super_seg_v4.card.yaml")
    cor = load_card(out / "ego_corridor_v3.card.yaml")
    assert 0.0 <= seg.metrics["sim_heldout"]["miou_level1"] <= 1.0
    assert 0.0 <= cor.metrics["sim_heldout"]["corridor_iou"] <= 1.0
    assert seg.ms_per_frame["median_ms"] > 0
    assert seg.training["training_command"].startswith("slt train segmentation")
    if results["commands"]["segmentation"].count("slt train") == 2:  # real data: two stages
        assert "--init" in seg.training["training_command"]
        assert seg.training["first_stage"]["training_command"].startswith("slt train")
        assert any(d.get("expand_m") == 0.6 for d in seg.training["datasets"])
    assert "slt simulate dataset" in seg.training["dataset_command"]
    assert "Dice" in seg.training["loss"]
    assert "Dice" in cor.training["loss"]
