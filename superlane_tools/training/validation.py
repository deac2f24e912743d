"""Validation during training on the real dev sets; keep the weights best on the worst set.

Every ``validate_every`` steps the model in training is exported to ONNX (a temporary file) and
segments the real dev frames (never trained on) the way the shipped runtime does (resize to the
card's input, the exported half-resolution heads in onnxruntime, bilinear upsampling, argmax
down the tree) and is scored per set:

* ``tusimple_dev``: the last 30 TuSimple ``train_frames`` and the 6 labelled ``tusimple/frames``;
* ``culane_day_dev``: the held-out CULane day clip (driver 161; the driver-23 clip is trained on);
* ``culane_night``: the 10 CULane night frames;

each by the lane-marking F-measure of the segmentation against the labelled lanes (recall:
labelled lane points with a predicted marking pixel within 3 px; precision: predicted marking
pixels within 10 px of a labelled lane polyline, at 640 px image width), and

* ``camvid_val``: level-2 mIoU on every 4th CamVid ``val`` frame.

A model trained in the canonical camera (``--canonical-camera``) is validated the way
``slt reprocess --canonical-camera`` runs it: the frames of a lane set are resampled into the
canonical camera and the labels mapped back to the frame's pixels. TuSimple's camera is its
profile; each CULane set's camera is estimated from its own frames with the labels unused
(:func:`estimated_camera`, as ``pipelines/real_frames_eval.py`` does for its end-to-end CULane
numbers); CamVid (no lane labels, camera unknown) is resized as it is, as it is trained.
Every history entry carries :data:`PROTOCOL`: entries of another protocol (a checkpoint from
before a change of the sets or of their cameras) are not compared with new ones.

The worst set's score decides: the weights whose worst set is the best so far are written
(atomically) beside the checkpoint as ``NAME.best.pt``. Against a reference model (``slt train
--validate-against``, the default that a new model must beat), the worst *margin* decides
instead: per set the score minus the reference's score on the same frames, the smallest margin
over the sets. The worst-set rule keeps the weights best on the hardest set, which is not the
set a release loses on (the CULane day clip is hardest for every model; CamVid is where the
canonical model falls below ``super_seg_v4``); the margin rule keeps the weights nearest to
beating the reference everywhere. The end-to-end chains
(``pipelines/real_frames_eval.py``: lanes fitted and scored with LaneEval, CULane F1) are the
release numbers; they take minutes and run on the exported model, not inside the loop.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.reporting.layout import TUSIMPLE_LABELS_FILE
from superlane_tools.training.checkpoint import save_checkpoint
from superlane_tools.training.errors import TrainingError

WIDTH = 640
"""Frames are scored at this width (labels scaled alike): tolerances mean the same on every set."""
RECALL_PX, PRECISION_PX = 3, 10
CAMVID_STRIDE = 4
CULANE_DAY_DEV = "culane/driver_161_06030819_0755"
CULANE_NIGHT = "culane/nightblur_0531_2336_0004"
PROTOCOL = 2
"""Version of the validation (sets, scores, cameras); 2: CULane in its estimated camera."""

Segmenter = Callable[[NDArray[np.uint8]], NDArray[np.uint8]]
"""BGR image -> leaf-id image of the same size."""


@dataclass(frozen=True)
class DevSet:
    """One real dev set, loaded once: scaled images and their labels.

    Attributes:
        name: Set name (the key of the scores).
        images: BGR frames scaled to :data:`WIDTH`.
        lanes: Per frame, the labelled lanes as ``(N, 2)`` pixel polylines (lane sets).
        codes: Per frame, node-code labels (CamVid), empty for lane sets.
        camera: The frames' camera (a profile name or a :class:`CameraModel`; "" = unknown),
            for the canonical camera.
    """

    name: str
    images: tuple[NDArray[np.uint8], ...]
    lanes: tuple[tuple[NDArray[np.float64], ...], ...] = ()
    codes: tuple[NDArray[np.uint8], ...] = ()
    camera: str | CameraModel = ""


def _scaled(path: Path) -> tuple[NDArray[np.uint8], float]:
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise TrainingError(f"validation: cannot read {path}")
    scale = WIDTH / image.shape[1]
    size = (WIDTH, round(image.shape[0] * scale))
    return np.asarray(cv2.resize(image, size, interpolation=cv2.INTER_AREA), np.uint8), scale


def _tusimple(root: Path) -> DevSet | None:
    from superlane_tools.training.datasets import (
        TUSIMPLE_VAL_FRAMES,
        _split_rows,
        tusimple_labels,
    )

    images, lanes = [], []
    for folder, split in (
        (root / "tusimple/train_frames", "val"),
        (root / "tusimple/frames", "all"),
    ):
        if not (folder / TUSIMPLE_LABELS_FILE).is_file():
            return None
        labels = tusimple_labels(folder)
        for label in labels[_split_rows(len(labels), split, TUSIMPLE_VAL_FRAMES)]:
            image, scale = _scaled(folder / str(label["raw_file"]))
            rows = np.asarray(label["h_samples"], np.float64)
            polys = []
            for xs in label["lanes"]:
                x = np.asarray(xs, np.float64)
                keep = x >= 0
                if keep.sum() >= 2:
                    polys.append(np.stack([x[keep], rows[keep]], axis=1) * scale)
            images.append(image)
            lanes.append(tuple(polys))
    return DevSet("tusimple_dev", tuple(images), tuple(lanes), camera="tusimple")


def _culane(root: Path, folder: str, name: str) -> DevSet | None:
    from superlane_tools.evaluation.culane import read_lines_file

    paths = sorted((root / folder).glob("*.jpg"))
    if not paths:
        return None
    images, lanes = [], []
    for path in paths:
        image, scale = _scaled(path)
        lines = read_lines_file(path.with_name(path.stem + ".lines.txt"))
        images.append(image)
        lanes.append(tuple(np.asarray(pts, np.float64) * scale for pts in lines if len(pts) >= 2))
    from superlane_tools.camera.errors import CameraError

    try:
        camera: str | CameraModel = estimated_camera(images, name)
    except CameraError:  # too few frames show both ego lines: segmented as they are
        camera = ""
    return DevSet(name, tuple(images), tuple(lanes), camera=camera)


def estimated_camera(images: Sequence[NDArray[np.uint8]], name: str) -> CameraModel:
    """Estimate the camera of frames of an unknown camera from the frames alone (no labels).

    The classical backend's lane-line pixels of each frame give its two ego lines; their
    vanishing points and a 3.7 m lane give pitch, yaw, roll and height; the intrinsics assume
    the dashcam field of view (``camera.extrinsics_estimate.frame_intrinsics``).

    Raises:
        TrainingError: If there are no frames.
    """
    from superlane_tools.camera.extrinsics_estimate import (
        estimate_extrinsics,
        frame_intrinsics,
        frame_lines,
    )
    from superlane_tools.hierarchy import LEAF_IDS
    from superlane_tools.lanes import CODE_OF
    from superlane_tools.scene.classical import ClassicalExtractor

    if not images:
        raise TrainingError(f"validation: no frames to estimate the camera of {name}")
    lut = np.zeros(256, dtype=bool)
    for node in CODE_OF:
        leaf = LEAF_IDS.get(node)
        if leaf is not None:
            lut[leaf] = True
    backend = ClassicalExtractor()
    k, _ = frame_intrinsics(images[0].shape[1], images[0].shape[0], None, None, None)
    lines = []
    for index, image in enumerate(images):
        rows, cols = np.nonzero(lut[backend.segment(image)])
        lines.append(frame_lines(np.stack([cols, rows], axis=1).astype(np.float64), k, index))
    return CameraModel(k, estimate_extrinsics(lines, k, 3.7).extrinsics, name=name)


def _camvid(root: Path) -> DevSet | None:
    from superlane_tools.scene.adapters.loader import load_adapter
    from superlane_tools.training.datasets import camvid_pairs
    from superlane_tools.training.label_io import read_label_ids

    if not (root / "camvid" / "val").is_dir():
        return None
    adapter = load_adapter("camvid")
    images, codes = [], []
    for image_path, label_path in camvid_pairs(root / "camvid", "val")[::CAMVID_STRIDE]:
        import cv2

        image = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
        if image is None:
            raise TrainingError(f"validation: cannot read {image_path}")
        images.append(np.asarray(image, np.uint8))
        codes.append(adapter.to_codes(read_label_ids(label_path)))
    return DevSet("camvid_val", tuple(images), codes=tuple(codes))


def real_dev_sets(root: Path) -> list[DevSet]:
    """Load every real dev set found under the real-data folder ``root`` (once per process).

    Raises:
        TrainingError: If none is there.
    """
    return list(_dev_sets(str(Path(root).resolve())))


@cache
def _dev_sets(folder: str) -> tuple[DevSet, ...]:
    root = Path(folder)
    found = [
        _tusimple(root),
        _culane(root, CULANE_DAY_DEV, "culane_day_dev"),
        _culane(root, CULANE_NIGHT, "culane_night"),
        _camvid(root),
    ]
    sets = tuple(s for s in found if s is not None and s.images)
    if not sets:
        raise TrainingError(f"validation: no real dev set under {root}")
    return sets


def marking_f(
    labels: Sequence[NDArray[np.uint8]], lanes: Sequence[Sequence[NDArray[np.float64]]]
) -> float:
    """Return the F-measure of lane-marking pixels against labelled lane polylines.

    Recall: labelled lane points (the polylines' vertices) with a predicted marking pixel within
    :data:`RECALL_PX`; precision: predicted marking pixels within :data:`PRECISION_PX` of a
    labelled polyline. Frames without a labelled lane count for precision only.
    """
    import cv2

    from superlane_tools.hierarchy import leaf_ids_under

    ids = np.asarray(leaf_ids_under("lane_marking"))
    hits = total = near = marked = 0
    for label, polys in zip(labels, lanes, strict=True):
        marking = np.isin(label, ids)
        height, width = marking.shape
        dist = cv2.distanceTransform((~marking).astype(np.uint8), cv2.DIST_L2, 3)
        band = np.zeros(marking.shape, np.uint8)
        for poly in polys:
            cols = np.clip(np.round(poly[:, 0]).astype(int), 0, width - 1)
            rows = np.clip(np.round(poly[:, 1]).astype(int), 0, height - 1)
            total += len(cols)
            hits += int(np.count_nonzero(dist[rows, cols] <= RECALL_PX))
            pts = np.stack([cols, rows], axis=1).astype(np.int32)
            cv2.polylines(band, [pts], False, 1, thickness=2 * PRECISION_PX + 1)
        near += int(np.count_nonzero(marking & (band > 0)))
        marked += int(np.count_nonzero(marking))
    recall = hits / total if total else 0.0
    precision = near / marked if marked else 0.0
    return 2 * recall * precision / (recall + precision) if recall + precision > 0 else 0.0


def canonical_segmenter(segment: Segmenter, camera: str | CameraModel, canonical: Any) -> Segmenter:
    """Return ``segment`` run in the canonical camera, its labels mapped back to the frame.

    Args:
        segment: The segmenter of canonical images.
        camera: The frames' camera (profile name, YAML or model).
        canonical: The :class:`~superlane_tools.camera.canonical.CanonicalCamera`.
    """
    from superlane_tools.camera.canonical import canonical_maps
    from superlane_tools.camera.profiles import load_camera

    base = camera if isinstance(camera, CameraModel) else load_camera(camera)
    maps: dict[tuple[int, int], Any] = {}

    def run(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
        size = (image.shape[1], image.shape[0])
        if size not in maps:
            maps[size] = canonical_maps(base.resized(*size), canonical)
        return np.asarray(maps[size].labels_to_source(segment(maps[size].to_canonical(image))))

    return run


def score_sets(
    segment: Segmenter, sets: Sequence[DevSet], canonical: Any = None
) -> dict[str, float]:
    """Return each dev set's score (lane-marking F, or CamVid level-2 mIoU) for a segmenter.

    With ``canonical`` (a :class:`~superlane_tools.camera.canonical.CanonicalCamera`), the sets
    whose camera is known are segmented in it (:func:`canonical_segmenter`).
    """
    from superlane_tools.training.evaluate import level_miou

    scores = {}
    for dev in sets:
        run = segment
        if canonical is not None and dev.camera:
            run = canonical_segmenter(segment, dev.camera, canonical)
        labels = [run(image) for image in dev.images]
        if dev.codes:
            value = float(level_miou(labels, dev.codes, 2)["miou"])
        else:
            value = marking_f(labels, dev.lanes)
        scores[dev.name] = round(0.0 if np.isnan(value) else value, 4)
    return scores


def reference_scores(model: str, sets: Sequence[DevSet]) -> dict[str, float]:
    """Score a shipped model (a name or an ONNX file with its card) as it runs in the runtime.

    A model trained in the canonical camera runs in it (``pipelines/dev_scores.py`` prints these).
    """
    from superlane_tools.scene.canonical_backend import trained_canonical
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    backend = OnnxSegmentationBackend(model)
    return score_sets(backend.segment, sets, trained_canonical(backend.card))


def torch_segmenter(model: Any, spec: Any) -> Segmenter:
    """Return a segmenter running a torch segmentation network as the ONNX runtime runs it.

    Args:
        model: The exported module (half-resolution heads), in eval mode.
        spec: The card's :class:`~superlane_tools.scene.model_card.InputSpec`.
    """
    import torch

    from superlane_tools.scene.adapters.heads import HEADS, decode_heads
    from superlane_tools.scene.onnx_backend import preprocess, resize_labels, upsample_scores

    device = next(model.parameters()).device

    def segment(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
        with torch.no_grad():
            outputs = model(torch.from_numpy(preprocess(image, spec)).to(device))
        scores = upsample_scores([o.cpu().numpy() for o in outputs], spec)
        return resize_labels(decode_heads(scores, HEADS), image.shape[1], image.shape[0])

    return segment


def onnx_segmenter(model: Any, spec: Any, folder: Path) -> Segmenter:
    """Export the module to ONNX in ``folder`` and return a segmenter running it (onnxruntime).

    What ships is the ONNX graph, and onnxruntime runs a batch of one several times faster than
    torch on the CPU: a validation exports once (seconds) and then segments with it.
    """
    import onnxruntime as ort

    from superlane_tools.scene.adapters.heads import HEADS, decode_heads
    from superlane_tools.scene.onnx_backend import preprocess, resize_labels, upsample_scores
    from superlane_tools.training.export import export_onnx

    names = [h.name for h in HEADS]
    path = folder / "validation.onnx"
    export_onnx(model.cpu(), spec.shape, path, spec.name, names)
    options = ort.SessionOptions()
    options.intra_op_num_threads = 2
    session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])

    def segment(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
        outputs = session.run(names, {spec.name: preprocess(image, spec)})
        scores = upsample_scores(outputs, spec)
        return resize_labels(decode_heads(scores, HEADS), image.shape[1], image.shape[0])

    return segment


@dataclass
class Validator:
    """Validate every so many steps; keep the weights best on the worst real set.

    Attributes:
        sets: The dev sets.
        best_path: Where the best weights go (``NAME.best.pt``).
        history: Every validation so far: ``{step, scores, worst_set, worst, seconds}``.
        best: The best entry of ``history`` (None before the first validation).
        canonical: The canonical camera the model was trained in (None: none).
        reference: The reference model's name and its scores on the same sets: the weights
            with the best worst margin over it are kept (None: the best worst set).
    """

    sets: Sequence[DevSet]
    best_path: Path
    history: list[dict[str, Any]] = field(default_factory=list)
    best: dict[str, Any] | None = None
    canonical: Any = None
    reference: tuple[str, dict[str, float]] | None = None

    def key(self, entry: dict[str, Any]) -> float:
        """Return what the selection maximises (the worst margin, else the worst set's score)."""
        if self.reference is None:
            return float(entry["worst"])
        scores, ref = entry["scores"], self.reference[1]
        return float(min(scores[name] - ref[name] for name in scores if name in ref))

    def run(self, model: Any, exported: Any, spec: Any, step: int) -> dict[str, Any]:
        """Score ``model`` (through its exported module) at ``step``; save it when best."""
        import tempfile

        t0 = time.perf_counter()
        was_training = model.training
        device = next(model.parameters()).device
        model.eval()
        try:
            with tempfile.TemporaryDirectory() as tmp:
                segment = onnx_segmenter(exported, spec, Path(tmp))
                scores = score_sets(segment, self.sets, self.canonical)
        finally:
            model.to(device)
            model.train(was_training)
        worst_set = min(scores, key=lambda name: scores[name])
        entry = {
            "protocol": PROTOCOL,
            "step": step,
            "scores": scores,
            "worst_set": worst_set,
            "worst": scores[worst_set],
            "seconds": round(time.perf_counter() - t0, 2),
        }
        if self.reference is not None:
            entry["worst_margin"] = round(self.key(entry), 4)
        self.history.append(entry)
        if self.best is None or self.key(entry) > self.key(self.best):
            self.best = entry
            state = {"model": model.state_dict(), "validation": json.dumps(entry)}
            save_checkpoint(self.best_path, state)
        return entry

    def summary(self) -> dict[str, Any]:
        """Return the card's ``validation`` section."""
        if self.reference is None:
            rule = "keep the weights whose worst real dev set scores best "
            reference = {}
        else:
            rule = (
                f"keep the weights whose worst margin over {self.reference[0]} (score minus "
                "its score, per real dev set) is best "
            )
            reference = {"reference": {"model": self.reference[0], "scores": self.reference[1]}}
        return {
            "sets": [s.name for s in self.sets],
            "rule": rule + "(lane-marking F; CamVid level-2 mIoU)",
            **reference,
            "best": self.best,
            "history": self.history,
        }
