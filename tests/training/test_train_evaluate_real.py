"""The TuSimple marking measure counts right: all-marking and no-marking backends on real frames."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.training.evaluate import backend_marking_hit_rate


class _Constant:
    """A backend that labels every pixel with one leaf id."""

    name = "constant"

    def __init__(self, leaf: str) -> None:
        self.leaf_id = LEAF_IDS[leaf]

    def segment(self, image_bgr: NDArray[np.uint8]) -> NDArray[np.uint8]:
        return np.full(image_bgr.shape[:2], self.leaf_id, np.uint8)

    def segment_batch(self, images_bgr: Sequence[NDArray[np.uint8]]) -> list[NDArray[np.uint8]]:
        return [self.segment(i) for i in images_bgr]


def test_marking_hit_rate_bounds_on_real_frames(realdata: Path) -> None:
    frames = realdata / "tusimple" / "frames"
    everywhere = backend_marking_hit_rate(_Constant("dividing_white_dashed"), frames)
    assert everywhere["frames"] == 6
    assert everywhere["lane_points_on_markings"] == 1.0
    assert 0.0 < everywhere["markings_near_labelled_lanes"] < 0.1  # lanes are thin
    nowhere = backend_marking_hit_rate(_Constant("road"), frames)
    assert nowhere["lane_points_on_markings"] == 0.0
    assert math.isnan(nowhere["markings_near_labelled_lanes"])
