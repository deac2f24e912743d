"""Per-pixel entropy keeps the road slope of real segmentation masks off its bound.

Real TuSimple validation frames (never trained on) go through the shipped segmentation model and
the lane fit. With Eq. 2's entropy per metre, the noise of real masks drives the slope ``b`` to
``slope_bound`` on most frames (the far field shrinks, and the noise's entropy with it); per
pixel, few frames reach it (masks rendered from TuSimple train labels fit slopes between -0.01
and 0.02, 5th to 95th percentile of 99 frames).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from superlane_tools.camera import load_camera
from superlane_tools.lanes import FitParams, fit_frame
from superlane_tools.lanes.points import label_points
from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend
from superlane_tools.training.datasets import TUSIMPLE_VAL_FRAMES, _split_rows, tusimple_labels

FRAMES = 10


@pytest.fixture(scope="module")
def real_points(realdata: Path) -> list[tuple[np.ndarray, np.ndarray]]:
    folder = realdata / "tusimple" / "train_frames"
    labels = tusimple_labels(folder)
    held_out = labels[_split_rows(len(labels), "val", TUSIMPLE_VAL_FRAMES)][:FRAMES]
    backend = OnnxSegmentationBackend("super_seg_v3", threads=1)
    points = []
    for label in held_out:
        image = cv2.imread(str(folder / label["raw_file"]))
        pts = label_points(backend.segment(image))
        assert pts.road_uv is not None
        points.append((pts.lane_uv, pts.road_uv))
    return points


def test_pixel_entropy_keeps_the_slope_of_real_masks_off_its_bound(
    real_points: list[tuple[np.ndarray, np.ndarray]],
) -> None:
    camera = load_camera("tusimple")
    slopes = {}
    for pixel_entropy in (False, True):
        params = replace(FitParams(), pixel_entropy=pixel_entropy)
        slopes[pixel_entropy] = np.array(
            [fit_frame(lane, road, camera, params).b for lane, road in real_points]
        )
    bound = FitParams().slope_bound
    at_bound = {k: int(np.sum(np.abs(v) > 0.95 * bound)) for k, v in slopes.items()}
    # Measured: 5 of 10 frames at the bound per metre, 1 per pixel; mean |b| 0.033 vs 0.020.
    assert at_bound[False] >= 4, slopes[False]
    assert at_bound[True] <= at_bound[False] - 3, slopes[True]
    assert np.mean(np.abs(slopes[True])) < 0.75 * np.mean(np.abs(slopes[False]))
