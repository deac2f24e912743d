"""Heterogeneous training data: dataset entries, native readers and the fixed validation splits.

A dataset entry names its reader, its folder and a sampling weight (``--data tusimple=DIR``,
``--data camvid:0.5=DIR`` or a YAML list). Readers:

* ``sim`` (alias ``superlane``): a ``slt simulate dataset`` folder (leaf ids, corridor masks);
* ``tusimple``: a folder with ``labels.json`` in TuSimple format (:mod:`.tusimple_targets`);
* ``culane``: one CULane clip (``NNNNN.jpg`` with ``NNNNN.lines.txt``), lane lines drawn as
  markings and the road between them exactly as TuSimple's (:mod:`.tusimple_targets`); a clip
  is one split (train on one clip, validate on another: never split a clip by frame);
* ``camvid``: CamVid 11 classes (``CLASSES.txt``; ``train/`` and ``val/`` with ``images/`` and
  ``labels/``), ``road`` -> ``drivable``;
* any other bundled adapter (``cityscapes``, ``mapillary_vistas``, ``apollo``) or adapter YAML: an
  ``index.parquet`` folder whose label images are in that dataset's ids.

Each dataset trains exactly the hierarchy levels it labels (SUPER II-C): its node codes stop at
the finest level it knows (CamVid's road is ``drivable``), and ``levels`` can mask more.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.canonical import CanonicalCamera, CanonicalView
from superlane_tools.camera.model import CameraModel
from superlane_tools.config_files import load_document
from superlane_tools.errors import ConfigError
from superlane_tools.hierarchy import BY_NAME
from superlane_tools.reporting.layout import TUSIMPLE_LABELS_FILE
from superlane_tools.scene.adapters.heads import HEADS
from superlane_tools.scene.adapters.loader import load_adapter
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.label_io import read_label_ids
from superlane_tools.training.tusimple_targets import (
    corridor_target,
    label_polylines,
    road_and_marking_codes,
)

SPLITS = ("train", "val", "all")
TUSIMPLE_VAL_FRAMES = 30
"""The last this many frames of a TuSimple folder are its validation split (never trained on)."""
NATIVE = ("sim", "superlane", "tusimple", "culane", "camvid")


@dataclass(frozen=True)
class DatasetSpec:
    """One dataset of a heterogeneous training run.

    Attributes:
        reader: ``sim``, ``tusimple``, ``camvid`` or an adapter name / YAML path.
        folder: The dataset folder.
        weight: Relative sampling weight of the dataset (per step, not per frame).
        split: ``train``, ``val`` or ``all`` frames of the folder.
        levels: Hierarchy levels (1-4) this dataset trains; None = every level it labels.
        expand_m: ``tusimple`` and ``culane`` only: label a band this wide (metres) on each
            side of every marking as road (SUPER II-B, "expand the lane marking to its vicinity").
        camera: The frames' camera (profile name or YAML, e.g. one ``slt camera estimate``
            wrote) for the canonical camera; "" = the reader's own (``tusimple``: the
            ``tusimple`` profile; simulator folders: every frame's camera from the index;
            ``culane`` and others: unknown, frames left as they are).
    """

    reader: str
    folder: Path
    weight: float = 1.0
    split: str = "train"
    levels: tuple[int, ...] | None = None
    expand_m: float = 0.0
    camera: str = ""

    def text(self) -> str:
        """Return the entry as ``--data`` text."""
        weight = "" if self.weight == 1.0 else f":{self.weight:g}"
        return f"{self.reader}{weight}={self.folder}"


def parse_data_arg(text: str) -> DatasetSpec:
    """Parse ``READER[:WEIGHT]=DIR`` (or a bare ``DIR``, read as a simulator folder).

    Raises:
        TrainingError: If the weight is not a positive number.
    """
    head, sep, folder = text.partition("=")
    if not sep or os.sep in head or not head:
        return DatasetSpec("sim", Path(text))
    reader, _, weight_text = head.partition(":")
    try:
        weight = float(weight_text) if weight_text else 1.0
    except ValueError as err:
        raise TrainingError(f"--data {text!r}: weight {weight_text!r} is not a number") from err
    if weight <= 0:
        raise TrainingError(f"--data {text!r}: the weight must be > 0")
    return DatasetSpec(reader, Path(folder), weight)


def load_dataset_list(path: str | os.PathLike[str]) -> tuple[DatasetSpec, ...]:
    """Read a YAML list: ``datasets: [{reader, folder, weight?, split?, levels?, expand_m?}]``.

    Relative folders (and camera YAML files) are relative to the YAML file.

    Raises:
        TrainingError: If the file cannot be read or an entry is malformed.
    """
    source = Path(path)
    try:
        data = load_document(source, "dataset list", ".yaml")
    except ConfigError as err:
        raise TrainingError(str(err)) from err
    entries = data.get("datasets") if isinstance(data, dict) else data
    if not isinstance(entries, list) or not entries:
        raise TrainingError(f"{source}: expected a non-empty `datasets:` list")
    specs = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, dict) or "reader" not in entry or "folder" not in entry:
            raise TrainingError(f"{source}: entry {i} needs `reader` and `folder`")
        folder = Path(str(entry["folder"]))
        levels = entry.get("levels")
        try:
            spec = DatasetSpec(
                str(entry["reader"]),
                folder if folder.is_absolute() else source.parent / folder,
                float(entry.get("weight", 1.0)),
                str(entry.get("split", "train")),
                None if levels is None else tuple(int(v) for v in levels),
                float(entry.get("expand_m", 0.0)),
                _relative_camera(str(entry.get("camera", "")), source.parent),
            )
        except (TypeError, ValueError) as err:
            raise TrainingError(f"{source}: entry {i}: {err}") from err
        specs.append(validate_spec(spec))
    return tuple(specs)


def _relative_camera(camera: str, folder: Path) -> str:
    """Return a camera YAML path relative to ``folder`` as a full path (profile names as is)."""
    if camera.endswith((".yaml", ".yml")) and not Path(camera).is_absolute():
        return str(folder / camera)
    return camera


def validate_spec(spec: DatasetSpec) -> DatasetSpec:
    """Return ``spec`` after checking its split, weight and levels.

    Raises:
        TrainingError: If any of them is invalid.
    """
    if spec.split not in SPLITS:
        raise TrainingError(f"{spec.text()}: split must be one of {SPLITS}, got {spec.split!r}")
    if spec.weight <= 0:
        raise TrainingError(f"{spec.text()}: the weight must be > 0")
    if spec.levels is not None and not set(spec.levels) <= {1, 2, 3, 4}:
        raise TrainingError(f"{spec.text()}: levels must lie in 1..4, got {spec.levels}")
    if spec.expand_m < 0 or (spec.expand_m > 0 and spec.reader not in ("tusimple", "culane")):
        raise TrainingError(
            f"{spec.text()}: expand_m must be >= 0 and applies to the tusimple and culane readers"
        )
    return spec


def head_level(index: int) -> int:
    """Return the hierarchy level a head classifies (1 for the root head)."""
    parent = HEADS[index].parent
    return 1 if not parent else BY_NAME[parent].level + 1


@dataclass(frozen=True)
class LoadedSet:
    """One dataset in memory at its training size.

    Attributes:
        spec: The entry it came from.
        images: ``(N, H, W, 3)`` uint8 BGR images.
        codes: ``(N, H, W)`` uint8 node codes (0 = void), or None (no segmentation labels).
        corridor: ``(N, H, W)`` uint8 ego-lane targets (0, 1, 255 = unknown), or None.
        names: Frame names.
        heads: Per head of :data:`HEADS`: whether this dataset trains it.
        canonical: The frames were resampled into the canonical camera.
    """

    spec: DatasetSpec
    images: NDArray[np.uint8]
    codes: NDArray[np.uint8] | None
    corridor: NDArray[np.uint8] | None
    names: tuple[str, ...]
    heads: tuple[bool, ...]
    canonical: bool = False


def _split_rows(n: int, split: str, val: int) -> slice:
    if split == "all":
        return slice(0, n)
    if n <= val:
        if split == "val":
            return slice(0, n)
        raise TrainingError(f"only {n} frames: too few to hold out {val} for validation")
    return slice(n - val, n) if split == "val" else slice(0, n - val)


def _resize(image: NDArray[Any], size: tuple[int, int], nearest: bool) -> NDArray[np.uint8]:
    import cv2

    if image.shape[1] == size[0] and image.shape[0] == size[1]:
        return np.asarray(image, np.uint8)
    mode = cv2.INTER_NEAREST if nearest else cv2.INTER_AREA
    return np.asarray(cv2.resize(image, size, interpolation=mode), np.uint8)


def _imread(path: Path) -> NDArray[np.uint8]:
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise TrainingError(f"cannot read image {path}")
    return np.asarray(image, np.uint8)


def tusimple_labels(folder: Path) -> list[dict[str, Any]]:
    """Return the label lines of ``folder/labels.json`` in file order.

    Raises:
        TrainingError: If the file is missing or a line is not JSON.
    """
    path = folder / TUSIMPLE_LABELS_FILE
    try:
        text = path.read_text(encoding="utf-8")
        return [json.loads(line) for line in text.splitlines() if line.strip()]
    except (OSError, json.JSONDecodeError) as err:
        raise TrainingError(f"cannot read TuSimple labels {path}: {err}") from err


def read_tusimple(
    spec: DatasetSpec,
    size: tuple[int, int],
    max_frames: int | None = None,
    canonical: CanonicalCamera | None = None,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8], NDArray[np.uint8], tuple[str, ...]]:
    """Return images, node codes, corridor targets and names of a TuSimple folder's split.

    With ``canonical``, every frame is resampled into that camera from ``spec.camera`` (default
    the ``tusimple`` profile) and the label polylines are mapped exactly (then rasterised).
    """
    labels = tusimple_labels(spec.folder)
    labels = labels[_split_rows(len(labels), spec.split, TUSIMPLE_VAL_FRAMES)][:max_frames]
    images, codes, corridors, names = [], [], [], []
    width, height = size
    base = _spec_camera(spec, "tusimple") if canonical is not None else None
    for label in labels:
        image = _imread(spec.folder / str(label["raw_file"]))
        if base is not None and canonical is not None:
            cam = base.resized(image.shape[1], image.shape[0])
            view = CanonicalView(cam, canonical)
            images.append(view.image(image))
            lines = [view.points(line) for line in label_polylines(label, 1.0, 1.0)]
            lines = [line for line in lines if len(line) >= 2]
        else:
            lines = label_polylines(label, width / image.shape[1], height / image.shape[0])
            images.append(_resize(image, size, nearest=False))
        codes.append(road_and_marking_codes(lines, width, height, spec.expand_m))
        corridors.append(corridor_target(lines, width, height))
        names.append(str(label["raw_file"]))
    return np.stack(images), np.stack(codes), np.stack(corridors), tuple(names)


def culane_frames(folder: Path) -> list[Path]:
    """Return the frames of a CULane clip folder that have a ``.lines.txt`` label, sorted.

    Raises:
        TrainingError: If there is none.
    """
    frames = [p for p in sorted(folder.glob("*.jpg")) if culane_label_path(p).is_file()]
    if not frames:
        raise TrainingError(f"{folder}: no CULane NNNNN.jpg + NNNNN.lines.txt pairs")
    return frames


def culane_label_path(image: Path) -> Path:
    """Return the ``.lines.txt`` label file of a CULane frame."""
    return image.with_name(image.stem + ".lines.txt")


def culane_polylines(image: Path) -> list[NDArray[np.float64]]:
    """Return a CULane frame's labelled lanes as ``(K, 2)`` pixel polylines, top to bottom.

    Raises:
        TrainingError: If the label file is unreadable or malformed.
    """
    from superlane_tools.evaluation.culane import read_lines_file
    from superlane_tools.evaluation.errors import EvaluationError

    try:
        lanes = read_lines_file(culane_label_path(image))
    except EvaluationError as err:
        raise TrainingError(str(err)) from err
    lines = []
    for lane in lanes:
        pts = np.asarray(lane, np.float64).reshape(-1, 2)
        pts = pts[np.argsort(pts[:, 1], kind="stable")]
        if len(pts) >= 2:
            lines.append(pts)
    return lines


def read_culane(
    spec: DatasetSpec,
    size: tuple[int, int],
    max_frames: int | None = None,
    canonical: CanonicalCamera | None = None,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8], NDArray[np.uint8], tuple[str, ...]]:
    """Return images, node codes, corridor targets and names of one CULane clip.

    The ``.lines.txt`` lanes become markings (paint width from the labelled lane gaps), the road
    between the outer lanes and the ego lane, as for TuSimple. With ``canonical`` every frame is
    resampled from ``spec.camera`` (required: CULane's camera is unknown, estimate it) and the
    lanes are mapped exactly. The whole clip is one split: ``split: val`` is refused.

    Raises:
        TrainingError: On ``split: val``, a missing camera, or unreadable frames or labels.
    """
    if spec.split == "val":
        raise TrainingError(
            f"{spec.text()}: a CULane clip is split by clip, not by frame: "
            "validate on another clip's folder"
        )
    if canonical is not None and not spec.camera:
        raise TrainingError(f"{spec.text()}: the canonical camera needs the clip's `camera`")
    width, height = size
    base = _spec_camera(spec, "") if canonical is not None else None
    images, codes, corridors, names = [], [], [], []
    for path in culane_frames(spec.folder)[:max_frames]:
        image = _imread(path)
        lines = culane_polylines(path)
        if base is not None and canonical is not None:
            view = CanonicalView(base.resized(image.shape[1], image.shape[0]), canonical)
            images.append(view.image(image))
            lines = [line for line in (view.points(line) for line in lines) if len(line) >= 2]
        else:
            scale = np.array([width / image.shape[1], height / image.shape[0]])
            lines = [line * scale for line in lines]
            images.append(_resize(image, size, nearest=False))
        codes.append(road_and_marking_codes(lines, width, height, spec.expand_m))
        corridors.append(corridor_target(lines, width, height))
        names.append(path.name)
    return np.stack(images), np.stack(codes), np.stack(corridors), tuple(names)


def camvid_pairs(folder: Path, split: str) -> list[tuple[Path, Path]]:
    """Return ``(image, label)`` paths of a CamVid root's split (or of one split folder).

    Raises:
        TrainingError: If the folder has no CamVid layout.
    """
    if (folder / "images").is_dir():
        roots = [folder]
    else:
        roots = [folder / s for s in (("train", "val") if split == "all" else (split,))]
    pairs = []
    for root in roots:
        for image in sorted((root / "images").glob("*.jpg")):
            label = root / "labels" / f"{image.stem}.png"
            if label.is_file():
                pairs.append((image, label))
    if not pairs:
        raise TrainingError(f"{folder}: no CamVid images/labels pairs for split {split!r}")
    return pairs


def read_camvid(
    spec: DatasetSpec, size: tuple[int, int], max_frames: int | None = None
) -> tuple[NDArray[np.uint8], NDArray[np.uint8], tuple[str, ...]]:
    """Return images, node codes and names of a CamVid split (``size`` keeps CamVid's 4:3)."""
    adapter = load_adapter("camvid")
    width = round(size[1] * 4 / 3 / 16) * 16
    target = (width, size[1])
    images, codes, names = [], [], []
    for image_path, label_path in camvid_pairs(spec.folder, spec.split)[:max_frames]:
        images.append(_resize(_imread(image_path), target, nearest=False))
        codes.append(_resize(adapter.to_codes(read_label_ids(label_path)), target, nearest=True))
        names.append(image_path.name)
    return np.stack(images), np.stack(codes), tuple(names)


def _index_folder(
    spec: DatasetSpec,
    task: str,
    size: tuple[int, int],
    max_frames: int | None,
    canonical: CanonicalCamera | None = None,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8] | None, NDArray[np.uint8] | None, tuple[str, ...]]:
    from superlane_tools.training.data import read_index

    column = "labels" if task == "segmentation" else "corridor"
    root, table = read_index(spec.folder, column)
    table = table.iloc[:max_frames]
    adapter = load_adapter("superlane" if spec.reader in ("sim", "superlane") else spec.reader)
    images, targets = [], []
    for row, (image_rel, target_rel) in enumerate(zip(table["image"], table[column], strict=True)):
        image = _imread(root / str(image_rel))
        ids = read_label_ids(root / str(target_rel))
        target = adapter.to_codes(ids) if task == "segmentation" else (ids > 0).astype(np.uint8)
        cam = index_camera(spec, table.iloc[row], image.shape) if canonical else None
        if cam is not None and canonical is not None:
            view = CanonicalView(cam, canonical)
            images.append(view.image(image))
            targets.append(view.image(np.asarray(target, np.uint8), nearest=True))
        else:
            images.append(_resize(image, size, nearest=False))
            targets.append(_resize(target, size, nearest=True))
    names = tuple(Path(str(p)).name for p in table["image"])
    stacked = np.stack(targets)
    if task == "segmentation":
        return np.stack(images), stacked, None, names
    return np.stack(images), None, stacked, names


def load_set(
    spec: DatasetSpec,
    task: str,
    size: tuple[int, int],
    max_frames: int | None = None,
    canonical: CanonicalCamera | None = None,
) -> LoadedSet:
    """Load one dataset entry for ``task`` at ``size = (width, height)``.

    With ``canonical`` (its size must be ``size``), frames whose camera is known or estimated
    (:func:`has_camera`) are resampled into the canonical camera; the others (CamVid, an
    adapter folder without ``camera``) are loaded as they are.

    Raises:
        TrainingError: If the folder cannot be read or has no labels for ``task``.
    """
    spec = validate_spec(spec)
    if not spec.folder.is_dir():
        raise TrainingError(f"{spec.text()}: no such folder")
    codes: NDArray[np.uint8] | None
    corridor: NDArray[np.uint8] | None
    if canonical is not None and (canonical.width, canonical.height) != size:
        raise TrainingError(f"the canonical camera is not {size[0]}x{size[1]}")
    if canonical is not None and (task != "segmentation" or not has_camera(spec)):
        canonical = None  # unknown camera (or the corridor task): frames stay as they are
    if spec.reader == "tusimple":
        images, codes, corridor, names = read_tusimple(spec, size, max_frames, canonical)
    elif spec.reader == "culane":
        images, codes, corridor, names = read_culane(spec, size, max_frames, canonical)
    elif spec.reader == "camvid":
        if task != "segmentation":
            raise TrainingError(f"{spec.text()}: CamVid has no ego-lane labels (task {task})")
        images, codes, names = read_camvid(spec, size, max_frames)
        corridor = None
    else:
        images, codes, corridor, names = _index_folder(spec, task, size, max_frames, canonical)
    if task == "corridor":
        codes = None
    heads = tuple(spec.levels is None or head_level(i) in spec.levels for i in range(len(HEADS)))
    return LoadedSet(spec, images, codes, corridor, names, heads, canonical is not None)


SIM_CAMERA_COLUMNS = ("fx", "fy", "cx", "cy", "camera_height_m", "pitch_rad", "roll_rad")
"""Index columns of a simulator folder that give every frame's camera (``slt simulate dataset``)."""


def has_camera(spec: DatasetSpec) -> bool:
    """Return True if the entry's frames have a known or estimated camera.

    TuSimple (its profile), simulator folders (every frame's camera in the index) and any entry
    with ``camera`` do; CamVid and other adapter folders do not.
    """
    return bool(spec.camera) or spec.reader in ("tusimple", "sim", "superlane")


def _spec_camera(spec: DatasetSpec, default: str) -> CameraModel:
    from superlane_tools.camera.errors import CameraError
    from superlane_tools.camera.profiles import load_camera

    try:
        return load_camera(spec.camera or default)
    except CameraError as err:
        raise TrainingError(f"{spec.text()}: {err}") from err


def index_camera(spec: DatasetSpec, row: Any, shape: tuple[int, ...]) -> CameraModel | None:
    """Return a frame's camera: the entry's ``camera``, else the index row's (simulator)."""
    if spec.camera:
        return _spec_camera(spec, "").resized(shape[1], shape[0])
    if not all(c in row.index for c in SIM_CAMERA_COLUMNS):
        return None
    from superlane_tools.camera.model import Extrinsics, Intrinsics

    intr = Intrinsics(shape[1], shape[0], row["fx"], row["fy"], row["cx"], row["cy"])
    extr = Extrinsics(
        row["camera_height_m"], row["pitch_rad"], row["roll_rad"], float(row.get("yaw_rad", 0.0))
    )
    return CameraModel(intr, extr, name="sim")
