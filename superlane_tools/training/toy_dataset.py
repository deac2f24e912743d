"""A tiny procedural dataset in the ``slt simulate dataset`` layout, for tests and quick runs.

Frames are flat-shaded road scenes: sky, vegetation, a road trapezoid with white dashed and
yellow solid lane lines, a preceding vehicle box, and the ego corridor between the ego lane's
lines up to that vehicle. Not a substitute for the simulator: it proves the training loop, the
export and the runtimes end to end without it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.reporting.atomic import write_bytes_atomic
from superlane_tools.reporting.layout import DatasetLayout
from superlane_tools.reporting.parquet import write_table
from superlane_tools.reporting.provenance import Provenance


def toy_frame(
    rng: np.random.Generator, width: int, height: int
) -> tuple[NDArray[np.uint8], NDArray[np.uint8], NDArray[np.uint8]]:
    """Return one ``(image BGR, leaf ids, corridor mask)`` triple of ``width x height`` pixels."""
    import cv2

    horizon = int(height * rng.uniform(0.38, 0.5))
    vx = width / 2 + rng.uniform(-0.08, 0.08) * width
    labels = np.full((height, width), LEAF_IDS["sky"], dtype=np.uint8)
    labels[horizon:, :] = LEAF_IDS["vegetation"]
    image = np.zeros((height, width, 3), dtype=np.uint8)
    image[:horizon] = (rng.uniform(180, 240), rng.uniform(150, 200), rng.uniform(100, 140))
    image[horizon:] = (rng.uniform(30, 60), rng.uniform(90, 140), rng.uniform(40, 70))
    lane_w = width * rng.uniform(0.3, 0.42)
    offset = rng.uniform(-0.15, 0.15) * lane_w
    bottom = [vx + offset + k * lane_w for k in (-1.5, -0.5, 0.5, 1.5)]

    def line(k: int) -> NDArray[np.int32]:
        return np.array([[vx, horizon], [bottom[k], height - 1]], dtype=np.float64).astype(np.int32)

    road = np.array(
        [[vx - 2, horizon], [vx + 2, horizon], [bottom[3], height], [bottom[0], height]]
    )
    road_poly = road.astype(np.int32)
    gray = rng.uniform(70, 120)
    cv2.fillPoly(image, [road_poly], (gray, gray, gray))
    cv2.fillPoly(labels, [road_poly], LEAF_IDS["road"])
    corridor = np.zeros((height, width), dtype=np.uint8)
    ego = np.array([[vx, horizon], [bottom[2], height], [bottom[1], height]]).astype(np.int32)
    cv2.fillPoly(corridor, [ego], 255)
    thickness = max(1, width // 100)
    for k, (leaf, color) in enumerate(
        [
            ("dividing_yellow_solid", (0, 200, 230)),
            ("dividing_white_dashed", (235, 235, 235)),
            ("dividing_white_dashed", (235, 235, 235)),
            ("dividing_white_solid", (235, 235, 235)),
        ]
    ):
        p0, p1 = line(k)
        segments = 8 if "dashed" in leaf else 1
        for s in range(segments):
            if segments > 1 and s % 2:
                continue
            a = p0 + (p1 - p0) * s / segments
            b = p0 + (p1 - p0) * (s + 1) / segments
            pa, pb = tuple(int(v) for v in a), tuple(int(v) for v in b)
            cv2.line(image, pa, pb, color, thickness)
            cv2.line(labels, pa, pb, LEAF_IDS[leaf], thickness)
    depth = rng.uniform(0.25, 0.6)
    car_v = int(horizon + depth * (height - horizon))
    car_w = int(lane_w * depth * 0.8)
    car_u = int(vx + offset * depth)
    top = car_v - int(car_w * 0.7)
    cv2.rectangle(image, (car_u - car_w // 2, top), (car_u + car_w // 2, car_v), (40, 40, 160), -1)
    cv2.rectangle(
        labels, (car_u - car_w // 2, top), (car_u + car_w // 2, car_v), LEAF_IDS["vehicle"], -1
    )
    corridor[: car_v + 1] = 0
    noise = rng.normal(0, 6, image.shape)
    image = np.clip(image.astype(np.float64) + noise, 0, 255).astype(np.uint8)
    return image, labels, corridor


def write_toy_dataset(
    out: str | os.PathLike[str], frames: int = 8, width: int = 128, height: int = 64, seed: int = 0
) -> Path:
    """Write ``frames`` toy frames and ``index.parquet`` (image, labels, corridor) to ``out``.

    Returns:
        The dataset folder.
    """
    import cv2

    root = Path(out)
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(frames):
        image, labels, corridor = toy_frame(rng, width, height)
        names = {k: f"{k}/{i:05d}.png" for k in ("image", "labels", "corridor")}
        for key, array in (("image", image), ("labels", labels), ("corridor", corridor)):
            ok, encoded = cv2.imencode(".png", array)
            assert ok, "PNG encoding of a uint8 array cannot fail"
            write_bytes_atomic(root / names[key], encoded.tobytes())
        rows.append(names)
    command = f"write_toy_dataset(frames={frames}, width={width}, height={height}, seed={seed})"
    write_table(pd.DataFrame(rows), DatasetLayout(root).index, Provenance(command=command))
    return root
