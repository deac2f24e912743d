"""How many frames the lane fit's evidence rule (``fit.min_line_points``) changes.

Each frame is resized to reprocess's processing width (640 px), segmented with the default
model, and fitted twice with reprocess's fit parameters: with the rule off (0) and with each
given minimum. A frame changes when its fitted lines differ (count or ego pair). Frames of an
image folder are fitted on their own (no warm start); frames of a recording in order, as
``slt reprocess`` does (warm start from the previous frame's fit).

    python benchmarks/lane_support.py \
        --images $SLT_REALDATA/udacity/advanced_lane_lines/test_images \
        --camera tusimple --min-points 10 20 30 50
    python benchmarks/lane_support.py --recording sim.mcap --camera sim_default --min-points 40

Prints one line per minimum and, with ``--lines``, every line's pixel count with the rule off.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera import load_camera
from superlane_tools.camera.model import CameraModel
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.lanes.points import lane_points, road_points
from superlane_tools.lanes.result import LaneFit
from superlane_tools.lanes.sequence import SequentialFit, max_plausible_slope

WIDTH = 640


def _images(folder: Path) -> Iterator[NDArray[np.uint8]]:
    import cv2

    for path in sorted(folder.iterdir()):
        if path.suffix.lower() in (".jpg", ".jpeg", ".png"):
            image = cv2.imread(str(path))
            if image is not None:
                yield np.asarray(image)


def _recording(path: Path) -> Iterator[NDArray[np.uint8]]:
    from superlane_tools.recording import open_recording
    from superlane_tools.recording.images import decode_frame
    from superlane_tools.recording.streams import select_one_each

    with open_recording(path) as rec:
        topic = select_one_each(rec.topics(), {}).frames
        for msg in rec.messages(topics=[topic]):
            yield decode_frame(msg)


def _signature(fit: LaneFit) -> tuple[object, ...]:
    return (len(fit.lanes), fit.ego_left, fit.ego_right)


def main(argv: list[str] | None = None) -> int:
    """Fit every frame with the rule off and on; print how many frames change."""
    import cv2

    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--images", type=Path)
    src.add_argument("--recording", type=Path)
    ap.add_argument("--camera", required=True, help="camera profile of the frames")
    ap.add_argument("--min-points", type=int, nargs="+", default=[40])
    ap.add_argument("--limit", type=int, default=0, help="frames at most (0: all)")
    ap.add_argument("--lines", action="store_true", help="print every line's pixel count")
    args = ap.parse_args(argv)
    config = ReprocessConfig()
    base = config.fit_params
    fraction = config.tracking.max_slope_fraction
    backend = OnnxSegmentationBackend(None, threads=1)
    frames = _images(args.images) if args.images else _recording(args.recording)
    camera: CameraModel | None = None
    inputs = []
    for k, image in enumerate(frames):
        if args.limit and k >= args.limit:
            break
        h, w = image.shape[:2]
        size = (WIDTH, max(8, round(h * WIDTH / w))) if w > WIDTH else (w, h)
        small = np.asarray(cv2.resize(image, size, interpolation=cv2.INTER_AREA))
        if camera is None:
            camera = load_camera(args.camera).resized(*size)
        labels = backend.segment(small)
        uv, codes = lane_points(labels, seed=base.seed)
        road = road_points(labels, seed=base.seed) if uv.shape[0] < base.road_term_below else None
        inputs.append((uv, road, codes))
    assert camera is not None, "no frames"
    fits: dict[int, list[LaneFit]] = {}
    for minimum in [0, *args.min_points]:
        params = replace(base, min_line_points=minimum)
        seq = SequentialFit(params, max_plausible_slope(params, fraction), True)
        fits[minimum] = []
        for uv, road, codes in inputs:
            if args.images:  # stills: every frame on its own
                seq.reset()
            fits[minimum].append(seq.fit(uv, road, camera, codes))
    off = fits[0]
    if args.lines:
        for k, fit in enumerate(off):
            lines = ", ".join(f"{ln.offset_m:+.1f} m: {ln.n_points}" for ln in fit.lanes)
            print(f"frame {k}: {lines}")
    counts = [ln.n_points for fit in off for ln in fit.lanes]
    print(
        f"{len(off)} frames, {len(counts)} lines with the rule off; pixels per line: "
        f"min {min(counts, default=0)}, median {np.median(counts) if counts else 0:.0f}"
    )
    for minimum in args.min_points:
        on = fits[minimum]
        changed = sum(_signature(a) != _signature(b) for a, b in zip(off, on, strict=True))
        dropped = sum(len(a.lanes) - len(b.lanes) for a, b in zip(off, on, strict=True))
        ego = sum(
            (a.ego_left, a.ego_right) != (b.ego_left, b.ego_right) and len(a.lanes) == len(b.lanes)
            for a, b in zip(off, on, strict=True)
        )
        print(
            f"min_line_points {minimum}: {changed} of {len(off)} frames change "
            f"({dropped} lines fewer in all; {ego} with the same count and another ego pair)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
