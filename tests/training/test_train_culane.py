"""The CULane reader: real day frames of driver 23, lanes drawn as TuSimple's markings."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera.canonical import CanonicalCamera, CanonicalView
from superlane_tools.camera.profiles import load_camera
from superlane_tools.scene.adapters.heads import NODE_CODES
from superlane_tools.training.datasets import (
    DatasetSpec,
    culane_frames,
    culane_polylines,
    load_set,
)
from superlane_tools.training.errors import TrainingError

CLIP = "culane/driver_23_05151649_0422"
MARK = NODE_CODES["lane_marking"]


def _dense(line: np.ndarray) -> np.ndarray:
    """Points every pixel along a polyline."""
    out = []
    for a, b in itertools.pairwise(line):
        n = max(2, int(np.ceil(np.hypot(*(b - a)))) + 1)
        out.append(np.linspace(a, b, n))
    return np.concatenate(out)


def _check_on_lines(codes: np.ndarray, lines: list[np.ndarray]) -> None:
    """Marking pixels lie on the polylines; the polylines' pixels are markings."""
    height, width = codes.shape
    pts = np.concatenate([_dense(line) for line in lines])
    inside = (pts[:, 0] >= 0) & (pts[:, 0] < width - 0.5) & (pts[:, 1] >= 0)
    inside &= pts[:, 1] < height - 0.5
    cols, rows = np.round(pts[inside]).astype(int).T
    assert np.mean(codes[rows, cols] == MARK) > 0.95
    mrow, mcol = np.nonzero(codes == MARK)
    assert len(mrow) > 100
    dist = np.min(np.hypot(mcol[:, None] - pts[None, :, 0], mrow[:, None] - pts[None, :, 1]), 1)
    # paint width: at most a few pixels from the line at this size, even at the bottom
    assert np.percentile(dist, 99) < 6.0
    assert dist.max() < 12.0


def test_culane_reader_draws_markings_on_the_labelled_lanes(realdata: Path) -> None:
    folder = realdata / CLIP
    loaded = load_set(DatasetSpec("culane", folder), "segmentation", (820, 295), max_frames=3)
    assert loaded.codes is not None
    assert loaded.images.shape == (3, 295, 820, 3)
    assert loaded.names == tuple(p.name for p in culane_frames(folder)[:3])
    assert not loaded.canonical
    checked = 0
    for codes, name in zip(loaded.codes, loaded.names, strict=True):
        lines = [line * 0.5 for line in culane_polylines(folder / name)]
        if lines:
            _check_on_lines(codes, lines)
            assert (codes == NODE_CODES["road"]).sum() > 1000  # road between the outer lanes
            checked += 1
    assert checked >= 2


def test_culane_reader_maps_lanes_exactly_into_the_canonical_camera(realdata: Path) -> None:
    folder = realdata / CLIP
    canonical = CanonicalCamera.for_input(512, 160)
    spec = DatasetSpec("culane", folder, camera="tusimple")  # any known camera: the mapping
    loaded = load_set(spec, "segmentation", (512, 160), max_frames=2, canonical=canonical)
    assert loaded.canonical
    assert loaded.codes is not None
    first = culane_frames(folder)[0]
    view = CanonicalView(load_camera("tusimple").resized(1640, 590), canonical)
    lines = [view.points(_dense(line)) for line in culane_polylines(first)]
    lines = [line for line in lines if len(line) >= 2]
    assert lines
    marks = loaded.codes[0] == MARK
    pts = np.concatenate(lines)
    keep = (pts[:, 0] >= 0) & (pts[:, 0] < 511.5) & (pts[:, 1] >= 0) & (pts[:, 1] < 159.5)
    cols, rows = np.round(pts[keep]).astype(int).T
    assert np.mean(marks[rows, cols]) > 0.95


def test_culane_clip_is_never_split_by_frame(realdata: Path) -> None:
    with pytest.raises(TrainingError, match="split by clip"):
        load_set(DatasetSpec("culane", realdata / CLIP, split="val"), "segmentation", (64, 32), 1)
    with pytest.raises(TrainingError, match="no CULane"):
        load_set(DatasetSpec("culane", realdata / "tusimple"), "segmentation", (64, 32), 1)


def test_validation_segments_known_cameras_in_the_canonical_camera(realdata: Path) -> None:
    from superlane_tools.camera.model import CameraModel
    from superlane_tools.training.validation import DevSet, _culane, _tusimple, score_sets

    tus, cul = _tusimple(realdata), _culane(realdata, "culane/nightblur_0531_2336_0004", "n")
    assert tus is not None
    assert cul is not None
    assert tus.camera == "tusimple"
    assert isinstance(cul.camera, CameraModel)  # estimated from the clip's frames, labels unused
    seen: list[tuple[int, ...]] = []

    def segment(image: np.ndarray) -> np.ndarray:
        seen.append(image.shape)
        return np.full(image.shape[:2], 1, np.uint8)

    sets = [
        DevSet("t", tus.images[:1], tus.lanes[:1], camera="tusimple"),
        DevSet("n", cul.images[:1], cul.lanes[:1], camera=cul.camera),
        DevSet("u", cul.images[:1], cul.lanes[:1]),  # camera unknown: as it is
    ]
    score_sets(segment, sets, CanonicalCamera.for_input(512, 160))
    assert seen == [(160, 512, 3), (160, 512, 3), cul.images[0].shape]
    seen.clear()
    score_sets(segment, sets)
    assert seen == [tus.images[0].shape, cul.images[0].shape, cul.images[0].shape]
