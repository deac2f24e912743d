"""What differs between two runs, in one short line each; Markdown cells that stay cells."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from superlane_tools.fleet import DriveRun, difference_lines, run_differences
from superlane_tools.reporting.report import markdown_table


def _drive(k: int, backend: str, model: str = "", version: str = "1.0", **config: Any) -> DriveRun:
    check = {
        "backend": backend.partition(":")[0],
        "model": model,
        "plausible": True,
        "reason": f"{backend} plausible",
        "seconds": 1.0 + k,  # timings differ between any two runs: never listed
        "trials": [{"backend": "classical", "scores": {"x": k}}],
    }
    provenance = {
        "tool_version": version,
        "models": {model: f"{model}-sha256-{'0' * 40}"} if model else {},
        "config": {
            "segmentation": {"model": model or "super_seg_v4"},
            "kpi": {"category": f"cat{k}"},  # differs between drives by nature: ignored
            "resolved": {"segmentation_backend": backend, "segmentation_self_check": check},
            **config,
        },
    }
    return DriveRun(f"hash{k}", f"d{k}", Path(f"/runs/d{k}"), "uncategorised", "", provenance)


def test_the_backend_on_every_drive_is_one_line() -> None:
    base = [_drive(k, "classical") for k in range(3)]
    cand = [_drive(k, "onnx:super_seg_v4", "super_seg_v4") for k in range(3)]
    diff = run_differences(base, cand)
    lines = difference_lines(diff)
    assert lines[0] == "segmentation backend: base classical; candidate onnx:super_seg_v4"
    assert any(
        line.startswith("model super_seg_v4 (SHA-256): base -; candidate ") for line in lines
    )
    assert len(lines) == 2, lines  # the self-check's fields are folded, not headline lines
    folded = diff[diff["folded"]]
    assert set(folded["key"]) == {"backend", "model", "reason"}
    assert not diff["key"].str.contains("seconds|trials|category").any()


def test_values_that_vary_between_drives_are_counted() -> None:
    base = [_drive(0, "classical"), *(_drive(k, "onnx:super_seg_v4") for k in (1, 2))]
    cand = [_drive(k, "onnx:super_seg_v4") for k in range(3)]
    line = difference_lines(run_differences(base, cand))[0]
    assert line == (
        "segmentation backend: base classical on 1 of 3 drives, onnx:super_seg_v4 on 2 of 3 "
        "drives; candidate onnx:super_seg_v4"
    )


def test_identical_values_are_never_listed() -> None:
    base = [_drive(k, "classical", camera={"height_m": 1.5}) for k in range(2)]
    cand = [_drive(k, "classical", camera={"height_m": 1.5}) for k in range(2)]
    assert run_differences(base, cand).empty
    other = [_drive(k, "classical", version="2.0", camera={"height_m": 1.6}) for k in range(2)]
    lines = difference_lines(run_differences(base, other))
    assert lines == [
        "tool version: base 1.0; candidate 2.0",
        "camera.height_m: base 1.5; candidate 1.6",
    ]


def test_a_pipe_in_a_cell_does_not_break_the_table() -> None:
    table = markdown_table(pd.DataFrame({"KPI": ["bias |mean|", "a\nb"], "value": [1.0, 2.0]}))
    rows = table.splitlines()
    assert len(rows) == 4
    assert rows[2] == "| bias \\|mean\\| | 1.000 |"
    for row in rows:  # every row has exactly the header's cells (unescaped pipes)
        assert row.replace("\\|", "").count("|") == 3
