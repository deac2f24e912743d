"""The canonical-camera backend wrapper on real frames with the shipped ONNX model."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera import CameraModel, Extrinsics, Intrinsics, load_camera
from superlane_tools.camera.canonical import CanonicalCamera
from superlane_tools.lanes import FitParams
from superlane_tools.lanes.multilane_fit import fit_frame
from superlane_tools.lanes.points import lane_points, road_points
from superlane_tools.scene.canonical_backend import CanonicalBackend, canonical_for_card
from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

MODEL = "super_seg_v4"


@pytest.fixture(scope="module")
def backend() -> OnnxSegmentationBackend:
    return OnnxSegmentationBackend(MODEL, threads=1)


def _tusimple_frames(realdata: Path, n: int) -> list[np.ndarray]:
    import cv2

    paths = sorted((realdata / "tusimple" / "frames").glob("*.png"))[:n]
    assert len(paths) == n
    return [np.asarray(cv2.imread(str(p), cv2.IMREAD_COLOR), np.uint8) for p in paths]


def _identity_like_frame(realdata: Path) -> tuple[np.ndarray, CameraModel]:
    """A real TuSimple frame at the model's 512x288, shifted so its horizon sits on row 152.

    TuSimple's camera scaled to 512 px has f = 400 px and its horizon on row 95; 57 rows of
    shift put it on row 152: the canonical camera of a 512x288 model (pitch 0, f 400 px).
    """
    import cv2

    frame = _tusimple_frames(realdata, 1)[0]
    small = np.asarray(cv2.resize(frame, (512, 288), interpolation=cv2.INTER_AREA), np.uint8)
    shifted = np.zeros_like(small)
    shifted[57:] = small[:-57]
    canonical = CanonicalCamera.for_input(512, 288)
    cam = CameraModel(
        Intrinsics(512, 288, 400.0, 400.0, 255.5, canonical.horizon_row),
        Extrinsics(height_m=1.7167),
        name="identity-like",
    )
    return shifted, cam


def test_identity_like_canonical_camera_changes_nothing(
    realdata: Path, backend: OnnxSegmentationBackend
) -> None:
    image, cam = _identity_like_frame(realdata)
    canonical = canonical_for_card(backend.card)
    assert canonical == CanonicalCamera.for_input(512, 288)
    wrapped = CanonicalBackend(backend, cam, canonical)
    direct = backend.segment(image)
    through = wrapped.segment(image)
    np.testing.assert_array_equal(through, direct)
    params = FitParams.from_dict({"max_range_m": 60.0})
    fits = []
    for labels in (direct, through):
        uv, codes = lane_points(labels, seed=params.seed)
        fits.append(fit_frame(uv, road_points(labels, seed=params.seed), cam, params, None, codes))
    assert len(fits[0].lanes) >= 2  # a real frame's lanes, not an empty fit
    assert fits[0].ego_left == fits[1].ego_left
    assert fits[0].ego_right == fits[1].ego_right
    for a, b in zip(fits[0].lanes, fits[1].lanes, strict=True):
        assert (a.offset_m, a.a1, a.a2) == (b.offset_m, b.a1, b.a2)


def test_maps_are_computed_once_per_drive_and_labels_come_back_in_frame_pixels(
    realdata: Path, backend: OnnxSegmentationBackend
) -> None:
    import cv2

    frames = [
        np.asarray(cv2.resize(f, (640, 360), interpolation=cv2.INTER_AREA), np.uint8)
        for f in _tusimple_frames(realdata, 4)
    ]
    cam = load_camera("tusimple")
    wrapped = CanonicalBackend(backend, cam, CanonicalCamera.for_input(512, 288))
    assert wrapped.name == f"onnx:{MODEL}+canonical"
    assert wrapped.sha256 == backend.sha256
    with ThreadPoolExecutor(2) as pool:  # as reprocess prepares frames: on a thread pool
        labels = list(pool.map(wrapped.segment, frames))
    assert wrapped.maps_computed == 1
    maps = wrapped.maps(640, 360)
    assert wrapped.maps_computed == 1
    for out in labels:
        assert out.shape == (360, 640)
        assert out.dtype == np.uint8
        assert (out[~maps.covered()] == 0).all()  # unseen by the canonical camera: void
        assert (out[maps.covered()] > 0).mean() > 0.9  # seen: segmented
    # the lane markings land on the frame's markings: the same rows as the direct run's
    direct = backend.segment(frames[0])
    uv_direct, _ = lane_points(direct, seed=0)
    uv_canon, _ = lane_points(labels[0], seed=0)
    assert len(uv_canon) > 100
    near = uv_canon[uv_canon[:, 1] > 250]
    assert len(near) > 20
    dist = np.min(np.hypot(*(near[:, None, :] - uv_direct[None, :, :]).transpose(2, 0, 1)), axis=1)
    assert np.median(dist) < 3.0  # pixels of the recording, not of the canonical image
    frames.append(np.zeros((180, 320, 3), np.uint8))  # another size: another table
    wrapped.segment(frames[-1])
    assert wrapped.maps_computed == 2
