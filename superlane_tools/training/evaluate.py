"""Accuracy of trained models on simulator hold-out data and on real frames (no torch needed).

Simulator: mIoU per hierarchy level, lane-marking IoU, corridor IoU. Real frames: the fraction of
TuSimple lane points on predicted markings, and KITTI ego-lane IoU.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import leaf_ids_under, level_lut
from superlane_tools.reporting.layout import TUSIMPLE_LABELS_FILE
from superlane_tools.scene.backend import SegmentationBackend
from superlane_tools.scene.model_card import ModelCard, card_path_for, load_card, write_card
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.label_io import read_label_ids

FloatImage = NDArray[np.float32]


def _iou(pred: NDArray[np.bool_], gt: NDArray[np.bool_]) -> float:
    union = int(np.count_nonzero(pred | gt))
    return float(np.count_nonzero(pred & gt) / union) if union else float("nan")


def segmentation_scores(
    preds: Iterable[NDArray[np.uint8]], gts: Iterable[NDArray[np.uint8]]
) -> dict[str, float]:
    """Return mIoU per hierarchy level and lane-marking IoU of leaf-id predictions.

    Void ground-truth pixels are ignored. A level's mIoU averages the IoU of every class present
    in the ground truth at that level. ``lane_marking_iou`` treats all lane-marking leaves as one
    class (the binary mask the lane fit consumes).
    """
    luts = {level: level_lut(level) for level in (1, 2, 3, 4)}
    inter: dict[int, NDArray[np.int64]] = {lv: np.zeros(256, np.int64) for lv in luts}
    union: dict[int, NDArray[np.int64]] = {lv: np.zeros(256, np.int64) for lv in luts}
    present: dict[int, set[int]] = {lv: set() for lv in luts}
    marking_ids = list(leaf_ids_under("lane_marking"))
    m_inter = m_union = 0
    for pred, gt in zip(preds, gts, strict=True):
        valid = gt != 0
        for level, (lut, _) in luts.items():
            p, g = lut[pred][valid], lut[gt][valid]
            for cls in np.union1d(np.unique(p), np.unique(g)):
                inter[level][cls] += int(np.count_nonzero((p == cls) & (g == cls)))
                union[level][cls] += int(np.count_nonzero((p == cls) | (g == cls)))
            present[level].update(int(c) for c in np.unique(g))
        pm, gm = np.isin(pred, marking_ids) & valid, np.isin(gt, marking_ids) & valid
        m_inter += int(np.count_nonzero(pm & gm))
        m_union += int(np.count_nonzero(pm | gm))
    scores: dict[str, float] = {}
    for level in luts:
        ious = [inter[level][c] / union[level][c] for c in sorted(present[level]) if c > 0]
        scores[f"miou_level{level}"] = round(float(np.mean(ious)), 4) if ious else float("nan")
    scores["lane_marking_iou"] = round(m_inter / m_union, 4) if m_union else float("nan")
    return scores


def corridor_iou(
    probs: Iterable[FloatImage], masks: Iterable[NDArray[np.bool_]], threshold: float = 0.5
) -> float:
    """Return the IoU of thresholded corridor probabilities, pooled over all frames."""
    inter = union = 0
    for prob, mask in zip(probs, masks, strict=True):
        pred = prob >= threshold
        inter += int(np.count_nonzero(pred & mask))
        union += int(np.count_nonzero(pred | mask))
    return round(inter / union, 4) if union else float("nan")


def _read_image(path: Path, flags: int) -> NDArray[np.uint8]:
    import cv2

    image = cv2.imread(str(path), flags)
    if image is None:
        raise TrainingError(f"cannot read image {path}")
    return np.asarray(image, dtype=np.uint8)


def evaluate_segmentation_on_dataset(
    model: str | os.PathLike[str], data_dir: str | os.PathLike[str], rows: slice | None = None
) -> dict[str, float]:
    """Run a segmentation model over dataset rows (leaf-id labels) and score it."""
    import cv2

    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend
    from superlane_tools.training.data import read_index

    root, table = read_index(data_dir, "labels")
    table = table.iloc[rows] if rows is not None else table
    backend = OnnxSegmentationBackend(model)
    preds, gts = [], []
    for image_rel, label_rel in zip(table["image"], table["labels"], strict=True):
        preds.append(backend.segment(_read_image(root / str(image_rel), cv2.IMREAD_COLOR)))
        gts.append(read_label_ids(root / str(label_rel)))
    scores = segmentation_scores(preds, gts)
    scores["frames"] = len(preds)
    return scores


def evaluate_corridor_on_dataset(
    model: str | os.PathLike[str], data_dir: str | os.PathLike[str], rows: slice | None = None
) -> dict[str, float]:
    """Run a corridor model over dataset rows (single frames, no smoothing) and return its IoU."""
    import cv2

    from superlane_tools.scene.corridor_runtime import OnnxCorridorModel
    from superlane_tools.training.data import read_index

    root, table = read_index(data_dir, "corridor")
    table = table.iloc[rows] if rows is not None else table
    runtime = OnnxCorridorModel(model)
    probs, masks = [], []
    for image_rel, mask_rel in zip(table["image"], table["corridor"], strict=True):
        probs.append(runtime.probability(_read_image(root / str(image_rel), cv2.IMREAD_COLOR)))
        masks.append(_read_image(root / str(mask_rel), cv2.IMREAD_GRAYSCALE) > 0)
    return {"corridor_iou": corridor_iou(probs, masks), "frames": len(probs)}


def tusimple_marking_hit_rate(
    model: str | os.PathLike[str], frames_dir: str | os.PathLike[str], tol_px: float = 3.0
) -> dict[str, float]:
    """Score lane-marking predictions against TuSimple labels (``frames_dir/labels.json``).

    Returns the fraction of labelled lane points within ``tol_px`` of a predicted lane-marking
    pixel, and the fraction of predicted marking pixels within ``tol_px`` of a labelled lane
    polyline (a precision proxy).
    """
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    return backend_marking_hit_rate(OnnxSegmentationBackend(model), frames_dir, tol_px)


def backend_marking_hit_rate(
    backend: SegmentationBackend, frames_dir: str | os.PathLike[str], tol_px: float = 3.0
) -> dict[str, float]:
    """Score any segmentation backend's lane markings against TuSimple labels.

    The same measure as :func:`tusimple_marking_hit_rate`, for a backend object (e.g. the
    classical extractor, the point of comparison of the learned model).
    """
    import cv2

    root = Path(frames_dir)
    marking_ids = list(leaf_ids_under("lane_marking"))
    hits = total = near = predicted = 0
    frames = 0
    for line in (root / TUSIMPLE_LABELS_FILE).read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        label = json.loads(line)
        image = _read_image(root / label["raw_file"], cv2.IMREAD_COLOR)
        marking = np.isin(backend.segment(image), marking_ids)
        dist = cv2.distanceTransform((~marking).astype(np.uint8), cv2.DIST_L2, 5)
        lanes_mask = np.zeros(marking.shape, np.uint8)
        for lane in label["lanes"]:
            pts = [(x, y) for x, y in zip(lane, label["h_samples"], strict=True) if x >= 0]
            for x, y in pts:
                total += 1
                hits += int(dist[int(y), int(np.clip(x, 0, marking.shape[1] - 1))] <= tol_px)
            if len(pts) > 1:
                cv2.polylines(lanes_mask, [np.array(pts, np.int32)], False, 1, 1)
        lane_dist = cv2.distanceTransform((1 - lanes_mask).astype(np.uint8), cv2.DIST_L2, 5)
        predicted += int(marking.sum())
        near += int((lane_dist[marking] <= tol_px).sum())
        frames += 1
    return {
        "lane_points_on_markings": round(hits / total, 4) if total else float("nan"),
        "markings_near_labelled_lanes": round(near / predicted, 4) if predicted else float("nan"),
        "frames": frames,
        "tolerance_px": tol_px,
    }


def kitti_ego_lane_iou(
    model: str | os.PathLike[str], kitti_dir: str | os.PathLike[str]
) -> dict[str, float]:
    """Return the corridor model's IoU with KITTI's ego-lane ground truth.

    The ground truth is the magenta region of ``gt_um_lane_*.png``, for every ``image_um_*.png``
    with a ground truth beside it.
    """
    import cv2

    from superlane_tools.scene.corridor_runtime import OnnxCorridorModel

    root = Path(kitti_dir)
    runtime = OnnxCorridorModel(model)
    probs, masks = [], []
    for image_path in sorted(root.glob("image_um_*.png")):
        gt_path = root / image_path.name.replace("image_um_", "gt_um_lane_")
        if not gt_path.is_file():
            continue
        gt = _read_image(gt_path, cv2.IMREAD_COLOR).astype(np.int32)
        magenta = (gt[:, :, 0] > 127) & (gt[:, :, 2] > 127) & (gt[:, :, 1] < 128)
        probs.append(runtime.probability(_read_image(image_path, cv2.IMREAD_COLOR)))
        masks.append(magenta)
    return {"ego_lane_iou": corridor_iou(probs, masks), "frames": len(probs)}


def _level_table(level: int) -> tuple[NDArray[np.int64], NDArray[np.int64], list[str]]:
    """Return (node code -> class, leaf id -> class, class names) at ``level`` (-1 = void)."""
    from superlane_tools.hierarchy import BY_NAME, NODES, node_at_level
    from superlane_tools.scene.adapters.heads import NODE_CODES

    names = sorted({node_at_level(n.name, level) for n in NODES})
    by_code = np.full(256, -1, np.int64)
    by_leaf = np.full(256, -1, np.int64)
    for name, code in NODE_CODES.items():
        if name != "void":
            by_code[code] = names.index(node_at_level(name, level))
            if BY_NAME[name].leaf_id >= 0:
                by_leaf[BY_NAME[name].leaf_id] = by_code[code]
    return by_code, by_leaf, names


def level_miou(
    preds: Iterable[NDArray[np.uint8]], codes: Iterable[NDArray[np.uint8]], level: int
) -> dict[str, Any]:
    """Return the mIoU at ``level`` of leaf-id predictions against node-code ground truth.

    Ground truth coarser than ``level`` (CamVid's ``drivable`` at level 3) counts as its own
    node, and so does the prediction's ancestor at that depth; void pixels are ignored. Classes
    absent from the ground truth are left out of the mean.
    """
    by_code, by_leaf, names = _level_table(level)
    inter = np.zeros(len(names), np.int64)
    union = np.zeros(len(names), np.int64)
    present = np.zeros(len(names), bool)
    for pred, code in zip(preds, codes, strict=True):
        g, p = by_code[code], by_leaf[pred]
        valid = g >= 0
        g, p = g[valid], p[valid]
        present[np.unique(g)] = True
        for cls in np.union1d(np.unique(g), np.unique(p)):
            if cls < 0:
                continue
            inter[cls] += int(np.count_nonzero((g == cls) & (p == cls)))
            union[cls] += int(np.count_nonzero((g == cls) | (p == cls)))
    per_class = {names[c]: round(float(inter[c] / union[c]), 4) for c in np.nonzero(present)[0]}
    miou = float(np.mean(list(per_class.values()))) if per_class else float("nan")
    return {"miou": round(miou, 4), "per_class": per_class}


def camvid_scores(
    backend: SegmentationBackend, camvid_dir: str | os.PathLike[str], split: str = "val"
) -> dict[str, Any]:
    """Return level-1 and level-2 mIoU of a segmentation backend on a CamVid split."""
    import cv2

    from superlane_tools.scene.adapters.loader import load_adapter
    from superlane_tools.training.datasets import camvid_pairs

    adapter = load_adapter("camvid")
    preds, codes = [], []
    for image_path, label_path in camvid_pairs(Path(camvid_dir), split):
        preds.append(backend.segment(_read_image(image_path, cv2.IMREAD_COLOR)))
        codes.append(adapter.to_codes(read_label_ids(label_path)))
    l1, l2 = level_miou(preds, codes, 1), level_miou(preds, codes, 2)
    return {
        "miou_level1": l1["miou"],
        "miou_level2": l2["miou"],
        "iou_level2": l2["per_class"],
        "frames": len(preds),
        "split": split,
    }


def tusimple_corridor_scores(
    model: str | os.PathLike[str], folders: Iterable[tuple[Path, str]]
) -> dict[str, Any]:
    """Return a corridor model's IoU with the labelled TuSimple ego lane.

    The ego lane lies between the lines left and right of the image centre
    (:func:`superlane_tools.training.tusimple_targets.corridor_target`); only rows from the
    highest row both ego lines are labelled down to the bottom count (the far field is unknown).

    Args:
        model: Corridor ONNX model.
        folders: ``(TuSimple folder, split)`` pairs (e.g. ``train_frames`` ``val``).
    """
    import cv2

    from superlane_tools.scene.corridor_runtime import OnnxCorridorModel
    from superlane_tools.training.datasets import (
        TUSIMPLE_VAL_FRAMES,
        _split_rows,
        tusimple_labels,
    )
    from superlane_tools.training.tusimple_targets import (
        CORRIDOR_IGNORE,
        corridor_target,
        label_polylines,
    )

    runtime = OnnxCorridorModel(model)
    probs, masks, per_frame = [], [], []
    for folder, split in folders:
        labels = tusimple_labels(folder)
        for label in labels[_split_rows(len(labels), split, TUSIMPLE_VAL_FRAMES)]:
            image = _read_image(folder / str(label["raw_file"]), cv2.IMREAD_COLOR)
            height, width = image.shape[:2]
            target = corridor_target(label_polylines(label, 1.0, 1.0), width, height)
            valid = target != CORRIDOR_IGNORE
            if not valid.any():
                continue
            prob = runtime.probability(image)
            probs.append(np.where(valid, prob, 0.0).astype(np.float32))
            masks.append(target == 1)
            per_frame.append(corridor_iou([probs[-1]], [masks[-1]]))
    return {
        "corridor_iou": corridor_iou(probs, masks),
        "median_frame_iou": round(float(np.median(per_frame)), 4) if per_frame else float("nan"),
        "frames": len(probs),
    }


def time_model(
    model: str | os.PathLike[str], task: str, repeats: int = 20, threads: int = 2
) -> dict[str, Any]:
    """Return the median onnxruntime milliseconds per frame of a model at its input size.

    A segmentation model's time includes the upsampling of its logits to the input size
    (:func:`~superlane_tools.scene.onnx_backend.upsample_scores`), which its graph leaves to the
    runtime.
    """
    from superlane_tools.scene.onnx_backend import open_model, upsample_scores

    loaded = open_model(model, task, threads)
    spec = loaded.card.input
    tensor = np.random.default_rng(0).normal(size=spec.shape).astype(np.float32)

    def run() -> None:
        outputs = loaded.session.run(None, {spec.name: tensor})
        if task == "segmentation":
            upsample_scores(outputs, spec)

    for _ in range(3):
        run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(1000.0 * (time.perf_counter() - start))
    upsampled = ", logits upsampled to the input size" if task == "segmentation" else ""
    return {
        "median_ms": round(float(np.median(times)), 2),
        "input": f"{spec.width}x{spec.height}",
        "threads": threads,
        "runtime": f"onnxruntime CPU, network{upsampled} (no image resize, no decoding)",
    }


def update_card(
    model: str | os.PathLike[str], metrics: dict[str, Any], ms_per_frame: dict[str, Any]
) -> ModelCard:
    """Merge measured metrics and timings into the card beside ``model`` and rewrite it."""
    path = card_path_for(model)
    card = load_card(path)
    merged = {**dict(card.metrics), **metrics}
    new = replace(card, metrics=merged, ms_per_frame={**dict(card.ms_per_frame), **ms_per_frame})
    write_card(new, path)
    return new
