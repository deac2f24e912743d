"""CULane night frames end to end: estimate the unknown camera, segment, fit, export, score.

The 10 frames of ``culane/nightblur_0531_2336_0004`` come from another camera than TuSimple's,
at night; nothing about the camera is given. The camera is estimated the way ``slt camera
estimate`` does it (library calls, since the frames are not a recording): lane-line pixels of
the classical backend (no learned model, so no backend is favoured), per-frame ego lines,
pitch / yaw / roll / height with the lane width 3.7 m and the dash-cam field of view assumed
(:data:`superlane_tools.camera.extrinsics_estimate.DASHCAM_HFOV_DEG`). The labels are never
read for it. Then each backend runs the documented chain::

    slt segment FRAMES --out SEG --backend B --camera culane_night.yaml
    slt lanes fit SEG --camera culane_night.yaml --out lanes.parquet
    slt lanes export-tusimple lanes.parquet --camera culane_night.yaml --h-samples 250:590:10 \
        --out pred.json --raw-ext .jpg
    (each frame's lanes written as CULane NNNNN.lines.txt)
    slt eval culane PRED FRAMES --json

and the score is the official CULane F1 at IoU 0.5 (30 px wide lanes).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

FOLDER = "culane/nightblur_0531_2336_0004"
ROWS = "250:590:10"
"""Rows the fitted lanes are sampled at (the CULane labels start near row 250 of 590)."""


def estimate_camera(data: Path, out: Path) -> Path:
    """Estimate the CULane night camera from its frames (no labels); write the profile YAML."""
    import cv2

    from superlane_tools.camera.extrinsics_estimate import (
        estimate_extrinsics,
        frame_intrinsics,
        frame_lines,
    )
    from superlane_tools.camera.model import CameraModel
    from superlane_tools.camera.profiles import camera_to_yaml
    from superlane_tools.commands.camera_estimate import _LANE_LUT
    from superlane_tools.scene.classical import ClassicalExtractor

    backend = ClassicalExtractor()
    frames = sorted((data / FOLDER).glob("*.jpg"))
    lines, k, source = [], None, ""
    for index, path in enumerate(frames):
        image = cv2.imread(str(path))
        if k is None:
            k, source = frame_intrinsics(image.shape[1], image.shape[0], None, None, None)
        rows, cols = np.nonzero(_LANE_LUT[backend.segment(image)])
        uv = np.stack([cols, rows], axis=1).astype(np.float64)
        lines.append(frame_lines(uv, k, seed=index))
    assert k is not None, f"no frames in {data / FOLDER}"
    est = estimate_extrinsics(lines, k, 3.7)
    camera = CameraModel(k, est.extrinsics, name="culane_night")
    comment = (
        f"CULane night camera estimated by pipelines/culane_night.py from the {len(frames)} "
        f"frames (classical lane pixels, {est.frames_used} frames with both ego lines; "
        f"{source}; lane width 3.7 m); the labels were not used"
    )
    out.write_text(camera_to_yaml(camera, comment), encoding="utf-8")
    return out


def write_lines_files(pred_json: Path, out: Path) -> Path:
    """Write each frame of a TuSimple-format prediction file as a CULane ``.lines.txt``."""
    from superlane_tools.evaluation import load_jsonl
    from superlane_tools.evaluation.culane import format_lines

    out.mkdir(parents=True, exist_ok=True)
    for rec in load_jsonl(pred_json):
        lanes = []
        for xs in rec.lanes:
            pts = [(x, y) for x, y in zip(xs, rec.h_samples, strict=True) if x >= 0]
            if len(pts) >= 2:
                lanes.append(np.asarray(pts[::-1], dtype=np.float64))  # bottom row first
        name = Path(rec.raw_file).name.removesuffix(".jpg") + ".lines.txt"
        (out / name).write_text(format_lines(lanes), encoding="utf-8")
    return out


def culane_chain(
    options: list[str],
    backend: str,
    data: Path,
    work: Path,
    camera: Path,
    slt: Callable[..., tuple[str, str]],
) -> dict[str, Any]:
    """Run the chain for one backend (``options``: its ``slt segment`` options).

    Returns the ``slt eval culane`` score and the commands.
    """
    frames = data / FOLDER
    seg, lanes = work / f"culane_seg_{backend}", work / f"culane_lanes_{backend}.parquet"
    pred = work / f"culane_pred_{backend}.json"
    commands = [
        slt("segment", frames, "--out", seg, *options, "--camera", camera, "--overlay")[0],
        slt("lanes", "fit", seg, "--camera", camera, "--out", lanes)[0],
        slt("lanes", "export-tusimple", lanes, "--camera", camera, "--h-samples", ROWS,
            "--out", pred, "--raw-ext", ".jpg")[0],
    ]  # fmt: skip
    lines_dir = write_lines_files(pred, work / f"culane_lines_{backend}")
    commands.append(f"(pipelines/culane_night.py: {pred} -> {lines_dir}/NNNNN.lines.txt)")
    cmd, out = slt("eval", "culane", lines_dir, frames, "--json")
    commands.append(cmd)
    return {"score": json.loads(out), "commands": commands}
