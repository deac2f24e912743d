"""Outputs written while frames stream: Foxglove annotations and the overlay video."""

from __future__ import annotations

from pathlib import Path
from types import TracebackType

import numpy as np

from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.examples import lane_drawings, lane_parameters
from superlane_tools.drive.stages import Finished
from superlane_tools.reporting.run_layout import RunLayout


class LiveOutputs:
    """``annotations.mcap`` and ``overlay.mp4``, fed frame by frame; atomic on success.

    Args:
        out: Output folder.
        config: Run configuration (``output.annotations``, ``output.video``).
        camera_topic: The image topic the annotations belong to.
    """

    def __init__(self, out: Path, config: ReprocessConfig, camera_topic: str) -> None:
        from superlane_tools.reporting.annotations import AnnotationWriter
        from superlane_tools.reporting.video import OverlayVideo

        self.paths: list[Path] = []
        self._ann = (
            AnnotationWriter(RunLayout(out).annotations, camera_topic)
            if config.output.annotations
            else None
        )
        self._video = (
            OverlayVideo(RunLayout(out).overlay, config.output.video_fps or 15.0)
            if config.output.video
            else None
        )

    def __enter__(self) -> LiveOutputs:
        return self

    def add(self, done: Finished) -> None:
        """Add one finished frame."""
        prep = done.prepared
        if prep.image is None:
            return
        drawings = lane_drawings(done)
        h = prep.hough
        hough_lines = [
            np.array([[s.u0, s.v0], [s.u1, s.v1]])
            for s in ((h.left_line, h.right_line) if h is not None else ())
            if s is not None
        ]
        if self._ann is not None:
            scale = prep.source_size[0] / prep.image.shape[1]
            self._ann.add(
                prep.log_time_ns,
                [(d.uv * scale, d.colour, d.style, d.ego) for d in drawings],
                [line * scale for line in hough_lines],
                lane_parameters(done),
            )
        if self._video is not None:
            self._video.add(prep.image, drawings, hough_lines, done.net_mask)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        ok = exc_type is None
        for writer in (self._ann, self._video):
            if writer is not None:
                path = writer.close(ok)
                if path is not None:
                    self.paths.append(path)
