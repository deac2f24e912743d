"""CULane frames end to end: estimate the unknown camera, segment, fit, export, score.

Two real CULane sets, both from another camera than TuSimple's, nothing about the camera given:
the 10 night frames of ``culane/nightblur_0531_2336_0004`` (:data:`FOLDER`) and the held-out day
clip :data:`DAY_DEV_FOLDER` (driver 161, 60 frames, a crowded morning arterial). The other day
clip, :data:`DAY_TRAIN_FOLDER` (driver 23, 180 frames), is the one to train on: the split is by
clip, never by frame (neighbouring frames are 1-3 s apart). The camera is estimated the way
``slt camera estimate`` did it (library calls, since the frames are not a recording):
lane-line pixels of the classical backend (no learned model, so no backend is favoured),
per-frame ego lines, pitch / yaw / roll / height with the lane width 3.7 m and the dash-cam
field of view assumed (:data:`superlane_tools.camera.extrinsics_estimate.DASHCAM_HFOV_DEG`).
The labels are never read for it. Then each backend runs the documented chain::

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
DAY_DEV_FOLDER = "culane/driver_161_06030819_0755"
"""The held-out CULane day clip (validation and evaluation; never trained on)."""
DAY_TRAIN_FOLDER = "culane/driver_23_05151649_0422"
"""The CULane day clip to train on."""
ROWS = "250:590:10"
"""Rows the fitted lanes are sampled at (the CULane labels start near row 250 of 590)."""


def lane_lut() -> np.ndarray:
    """Return the leaf id -> "a lane-line pixel the fit uses" table (the estimate's pixels)."""
    from superlane_tools.hierarchy import LEAF_IDS
    from superlane_tools.lanes import CODE_OF

    lut = np.zeros(256, dtype=bool)
    for node in CODE_OF:
        leaf = LEAF_IDS.get(node)
        if leaf is not None:
            lut[leaf] = True
    return lut


def estimate_camera(data: Path, out: Path, folder: str = FOLDER) -> Path:
    """Estimate a CULane set's camera from its frames (no labels); write the profile YAML."""
    import cv2

    from superlane_tools.camera.extrinsics_estimate import (
        estimate_extrinsics,
        frame_intrinsics,
        frame_lines,
    )
    from superlane_tools.camera.model import CameraModel
    from superlane_tools.camera.profiles import camera_to_yaml
    from superlane_tools.scene.classical import ClassicalExtractor

    backend = ClassicalExtractor()
    frames = sorted((data / folder).glob("*.jpg"))
    lines, k, source = [], None, ""
    for index, path in enumerate(frames):
        image = cv2.imread(str(path))
        if k is None:
            k, source = frame_intrinsics(image.shape[1], image.shape[0], None, None, None)
        rows, cols = np.nonzero(lane_lut()[backend.segment(image)])
        uv = np.stack([cols, rows], axis=1).astype(np.float64)
        lines.append(frame_lines(uv, k, seed=index))
    assert k is not None, f"no frames in {data / folder}"
    est = estimate_extrinsics(lines, k, 3.7)
    camera = CameraModel(k, est.extrinsics, name=out.stem)
    comment = (
        f"CULane camera of {folder} estimated by pipelines/culane_night.py from the {len(frames)} "
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
    folder: str = FOLDER,
    tag: str = "culane",
) -> dict[str, Any]:
    """Run the chain for one backend (``options``: its ``slt segment`` options) on ``folder``.

    ``tag`` prefixes the work files (one per set). Returns the ``slt eval culane`` score and the
    commands.
    """
    frames = data / folder
    seg, lanes = work / f"{tag}_seg_{backend}", work / f"{tag}_lanes_{backend}.parquet"
    pred = work / f"{tag}_pred_{backend}.json"
    commands = [
        slt("segment", frames, "--out", seg, *options, "--camera", camera, "--overlay")[0],
        slt("lanes", "fit", seg, "--camera", camera, "--out", lanes)[0],
        slt("lanes", "export-tusimple", lanes, "--camera", camera, "--h-samples", ROWS,
            "--out", pred, "--raw-ext", ".jpg")[0],
    ]  # fmt: skip
    lines_dir = write_lines_files(pred, work / f"{tag}_lines_{backend}")
    commands.append(f"(pipelines/culane_night.py: {pred} -> {lines_dir}/NNNNN.lines.txt)")
    cmd, out = slt("eval", "culane", lines_dir, frames, "--json")
    commands.append(cmd)
    return {"score": json.loads(out), "commands": commands}
