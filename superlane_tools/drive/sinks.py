"""The frame sinks of a reprocess pass: per-frame tables, annotations, overlay video, examples.

Each takes the finished frames in order (:class:`~superlane_tools.drive.loop.FrameSink`) and
writes its file atomically when closed with ``ok=True`` (discards it otherwise). The paths come
from the caller (the command names them through :mod:`superlane_tools.reporting.layout`).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from superlane_tools.drive.examples import example_frame, lane_drawings, lane_parameters
from superlane_tools.drive.stages import Finished
from superlane_tools.lanes.table import fit_row
from superlane_tools.reporting import ParquetStreamWriter, Provenance
from superlane_tools.reporting.layout import STAGES, STREAMED_SCHEMAS
from superlane_tools.reporting.plots import example_plot

FLUSH_ROWS = 256
"""Frames buffered before the per-frame tables write a row group."""


def frame_rows(done: Finished, corridor_status: str, mean_frames: int) -> dict[str, dict[str, Any]]:
    """Return one row per streamed table (frames, lanes, corridor, baseline) for a frame."""
    prep = done.prepared
    image = prep.image
    ph, pw = (image.shape[:2]) if image is not None else (0, 0)
    frames = {
        "frame_index": prep.index,
        "log_time_ns": prep.log_time_ns,
        "stamp_ns": prep.stamp_ns,
        "width": prep.source_size[0],
        "height": prep.source_size[1],
        "process_width": pw,
        "process_height": ph,
        "ok": not prep.error,
        "error": prep.error,
        **{f"{s}_ms": prep.seconds.get(s, 0.0) * 1e3 for s in STAGES},
        **{f"{s}_cpu_ms": prep.cpu_seconds.get(s, 0.0) * 1e3 for s in STAGES},
    }
    lanes = {
        "frame_index": prep.index,
        "log_time_ns": prep.log_time_ns,
        **fit_row(f"{prep.index:06d}", pw, ph, done.fit),
        "c": done.fit.c if done.fit.ok else math.nan,
    }
    net = done.net_corridor
    corridor = {
        "frame_index": prep.index,
        "log_time_ns": prep.log_time_ns,
        "width_m": net.width_m,
        "length_m": net.length_m,
        "n_rows": net.n_rows,
        "mean_frames": mean_frames,
        "status": corridor_status or ("" if prep.image is not None else "frame not decoded"),
    }
    h = prep.hough
    baseline = {
        "frame_index": prep.index,
        "log_time_ns": prep.log_time_ns,
        "ok": bool(h.ok) if h else False,
        "width_m": h.width_m if h else math.nan,
        "range_m": h.range_m if h else math.nan,
        "reason": h.reason if h else "frame not decoded",
        "left_line_px": list(h.left_line) if h and h.left_line else None,
        "right_line_px": list(h.right_line) if h and h.right_line else None,
    }
    return {"frames": frames, "lanes": lanes, "corridor": corridor, "baseline": baseline}


class FrameTablesSink:
    """Streams the per-frame tables (frames, lanes, corridor, baseline) in row groups.

    Args:
        files: Path of each streamed table: ``frames``, ``lanes``, ``corridor``, ``baseline``.
        provenance: Provenance of every table.
        corridor_status: Why the corridor network is unavailable ("" when it is available).
        mean_frames: Frames of the corridor network's mean.
    """

    def __init__(
        self,
        files: Mapping[str, Path],
        provenance: Provenance,
        corridor_status: str,
        mean_frames: int,
    ) -> None:
        self.writers: dict[str, ParquetStreamWriter] = {}
        try:
            for name, schema in STREAMED_SCHEMAS.items():
                writer = ParquetStreamWriter(files[name], schema, provenance)
                self.writers[name] = writer.__enter__()
        except BaseException:
            self._exit(ok=False)
            raise
        self._rows: dict[str, list[dict[str, Any]]] = {name: [] for name in STREAMED_SCHEMAS}
        self._corridor_status, self._mean_frames = corridor_status, mean_frames

    def add(self, done: Finished) -> None:
        """Take one finished frame (frames come in order)."""
        for name, row in frame_rows(done, self._corridor_status, self._mean_frames).items():
            self._rows[name].append(row)
        if len(self._rows["frames"]) >= FLUSH_ROWS:
            self._flush()

    def _flush(self) -> None:
        for name, rows in self._rows.items():
            if rows:
                self.writers[name].write(pa.Table.from_pylist(rows, self.writers[name].schema))
                rows.clear()

    def close(self, ok: bool) -> list[Path]:
        """Write the buffered rows and publish the tables (``ok``), or discard them."""
        try:
            if ok:
                self._flush()
        except BaseException:
            self._exit(ok=False)
            raise
        self._exit(ok)
        return [w.path for w in self.writers.values()] if ok else []

    def _exit(self, ok: bool) -> None:
        """Close every writer (discarding the rest once one fails); raise the first failure."""
        failure: BaseException | None = None
        for writer in reversed(self.writers.values()):
            try:
                writer.__exit__(None if ok and failure is None else RuntimeError, None, None)
            except BaseException as err:  # a full disk: the other writers still close
                failure = failure or err
        if failure is not None:
            raise failure


def _hough_lines(done: Finished) -> list[NDArray[np.float64]]:
    """Return the Hough baseline's ego lines as 2x2 image point arrays (processing size)."""
    h = done.prepared.hough
    return [
        np.array([[s.u0, s.v0], [s.u1, s.v1]])
        for s in ((h.left_line, h.right_line) if h is not None else ())
        if s is not None
    ]


class AnnotationSink:
    """Foxglove annotations (``annotations.mcap``): lanes, Hough lines, lane parameters.

    Args:
        path: The annotations file.
        camera_topic: The image topic the annotations belong to.
    """

    def __init__(self, path: Path, camera_topic: str) -> None:
        from superlane_tools.reporting.annotations import AnnotationWriter

        self._writer = AnnotationWriter(path, camera_topic)

    def add(self, done: Finished) -> None:
        """Annotate one finished frame (in the source image's pixels)."""
        prep = done.prepared
        if prep.image is None:
            return
        scale = prep.source_size[0] / prep.image.shape[1]
        self._writer.add(
            prep.log_time_ns,
            [(d.uv * scale, d.colour, d.style, d.ego) for d in lane_drawings(done)],
            [line * scale for line in _hough_lines(done)],
            lane_parameters(done),
        )

    def close(self, ok: bool) -> list[Path]:
        """Finish the file (``ok``) or discard it."""
        path = self._writer.close(ok)
        return [path] if path is not None else []


class VideoSink:
    """The overlay video (``overlay.mp4``): lanes, Hough lines and the corridor over the image.

    Args:
        path: The video file.
        fps: Frame rate of the video, Hz.
    """

    def __init__(self, path: Path, fps: float) -> None:
        from superlane_tools.reporting.video import OverlayVideo

        self._video = OverlayVideo(path, fps)

    def add(self, done: Finished) -> None:
        """Draw one finished frame (processing size)."""
        prep = done.prepared
        if prep.image is not None:
            self._video.add(prep.image, lane_drawings(done), _hough_lines(done), done.net_mask)

    def close(self, ok: bool) -> list[Path]:
        """Finish the file (``ok``, and at least one frame) or discard it."""
        path = self._video.close(ok)
        return [path] if path is not None else []


class ExampleSink:
    """SUPER Fig. 8 style plots of a few frames, drawn on their own thread during the pass.

    Args:
        folder: Folder of the plots.
        indices: Frame indices to plot (:func:`~superlane_tools.drive.examples.example_indices`).
    """

    def __init__(self, folder: Path, indices: Collection[int]) -> None:
        self._folder, self._indices = folder, indices
        self._pool = ThreadPoolExecutor(1, "slt-example-plots")
        self._pngs: list[Future[Path]] = []

    def add(self, done: Finished) -> None:
        """Plot the frame if it is one of the examples (and was decoded)."""
        if done.prepared.index in self._indices and done.prepared.image is not None:
            example = example_frame(done)
            self._pngs.append(self._pool.submit(example_plot, example, self._folder))

    def close(self, ok: bool) -> list[Path]:
        """Wait for the plots (``ok``; their paths in frame order) or drop the pending ones."""
        self._pool.shutdown(wait=True, cancel_futures=not ok)
        return [f.result() for f in self._pngs] if ok else []
