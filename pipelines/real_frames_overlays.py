"""Overlay sheets of ``real_frames_eval.py``: labelled frames and KITTI's ego lane."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from superlane_tools.evaluation import load_jsonl
from superlane_tools.evaluation.kitti import decode_ground_truth
from superlane_tools.hierarchy import leaf_ids_under

MARKING_IDS = np.array(leaf_ids_under("lane_marking"))
KITTI_NAME = "um_000000"


def _draw_lanes(img: np.ndarray, rec: Any, colour: tuple[int, int, int]) -> None:
    for lane in rec.lanes:
        pts = [(round(x), int(y)) for x, y in zip(lane, rec.h_samples, strict=True) if x >= 0]
        for a, b in itertools.pairwise(pts):
            cv2.line(img, a, b, colour, 2)


def overlay_sheet(
    seg: Path, pred: Path, labels: Path | None, images: list[Path], out: Path
) -> None:
    """Write a half-size contact sheet: markings magenta, labels green, predictions red."""
    gts = {r.raw_file: r for r in load_jsonl(labels)} if labels else {}
    preds = {r.raw_file: r for r in load_jsonl(pred)}
    tiles = []
    for src in images:
        img = cv2.imread(str(src))
        lab = cv2.imread(str(next(seg.rglob(f"{src.stem}.png"))), cv2.IMREAD_UNCHANGED)
        img[lab == leaf_ids_under("road")[0]] //= 2
        img[np.isin(lab, MARKING_IDS)] = (255, 0, 255)
        if src.name in gts:
            _draw_lanes(img, gts[src.name], (0, 255, 0))
        key = next((k for k in preds if Path(k).stem == src.stem), None)
        if key is not None:
            _draw_lanes(img, preds[key], (0, 0, 255))
        tiles.append(cv2.resize(img, (img.shape[1] // 2, img.shape[0] // 2)))
    if len(tiles) % 2:
        tiles.append(np.zeros_like(tiles[0]))
    sheet = np.vstack([np.hstack(tiles[i : i + 2]) for i in range(0, len(tiles), 2)])
    cv2.imwrite(str(out), sheet, [cv2.IMWRITE_PNG_COMPRESSION, 9])


def kitti_overlay(data: Path, result: dict[str, Any], out: Path) -> None:
    """Write the KITTI frame with GT ego lane (green), fitted ego lane (red) and markings."""
    img = cv2.imread(str(data / "kitti_road" / f"image_{KITTI_NAME}.png"))
    gt_bgr = cv2.imread(str(data / "kitti_road" / f"gt_um_lane_{KITTI_NAME[3:]}.png"))
    gt = decode_ground_truth(gt_bgr[:, :, ::-1]).positive
    lab = cv2.imread(str(Path(result["seg"]) / f"image_{KITTI_NAME}.png"), cv2.IMREAD_UNCHANGED)
    img[gt] = (0.6 * img[gt] + (0, 100, 0)).astype(np.uint8)
    img[result["mask"]] = (0.6 * img[result["mask"]] + (0, 0, 100)).astype(np.uint8)
    img[np.isin(lab, MARKING_IDS)] = (255, 0, 255)
    cv2.imwrite(str(out), img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
