"""Overlay drawing and the review video (``overlay.mp4``, cv2 ``mp4v``), renamed into place."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.reporting.errors import OutputError

COLOURS_BGR = {"white": (255, 255, 255), "yellow": (0, 215, 255), "unknown": (255, 255, 0)}
"""Drawing colour of each lane colour (BGR)."""
HOUGH_BGR = (0, 0, 255)


def _dashed(image: Any, pts: NDArray[np.int32], colour: tuple[int, int, int], width: int) -> None:
    import cv2

    for k in range(0, len(pts) - 1, 2):
        cv2.line(
            image,
            tuple(int(v) for v in pts[k]),
            tuple(int(v) for v in pts[k + 1]),
            colour,
            width,
            cv2.LINE_AA,
        )


def draw_overlay(
    image_bgr: NDArray[np.uint8],
    lanes: Sequence[Any],
    hough_lines: Sequence[NDArray[np.float64]] = (),
    corridor: NDArray[np.float32] | None = None,
) -> NDArray[np.uint8]:
    """Draw fitted lanes (colour and style), Hough boundaries and the corridor on a copy.

    Args:
        image_bgr: ``(H, W, 3)`` frame.
        lanes: Items with ``uv`` (pixels), ``colour``, ``style`` and ``ego`` attributes.
        hough_lines: ``(2, 2)`` pixel segments of the Hough baseline (drawn thin, red).
        corridor: Corridor probability at any size (tinted green above 0.5), or None.
    """
    import cv2

    out = image_bgr.copy()
    height, width = out.shape[:2]
    if corridor is not None:
        prob = corridor
        if prob.shape != (height, width):
            prob = np.asarray(
                cv2.resize(prob, (width, height), interpolation=cv2.INTER_LINEAR), np.float32
            )
        mask = prob > 0.5
        out[mask] = (0.6 * out[mask] + 0.4 * np.array([0, 200, 0])).astype(np.uint8)
    for lane in lanes:
        pts = np.round(np.asarray(lane.uv)).astype(np.int32)
        if len(pts) < 2:
            continue
        colour = COLOURS_BGR.get(lane.colour, COLOURS_BGR["unknown"])
        thick = 3 if lane.ego else 2
        if lane.style == "dashed":
            _dashed(out, pts, colour, thick)
        else:
            cv2.polylines(out, [pts.reshape(-1, 1, 2)], False, colour, thick, cv2.LINE_AA)
            if lane.style == "double":
                cv2.polylines(
                    out,
                    [(pts + np.array([4, 0], np.int32)).reshape(-1, 1, 2)],
                    False,
                    colour,
                    1,
                    cv2.LINE_AA,
                )
    for seg in hough_lines:
        p = np.round(seg).astype(int)
        cv2.line(out, (p[0, 0], p[0, 1]), (p[1, 0], p[1, 1]), HOUGH_BGR, 1, cv2.LINE_AA)
    return out


class OverlayVideo:
    """MP4 (``mp4v``) of overlay frames, finalised atomically by :meth:`close`.

    Args:
        path: Target ``.mp4``.
        fps: Frame rate, Hz.
    """

    def __init__(self, path: Path, fps: float) -> None:
        self.path = path
        self.fps = fps
        # cv2 picks the container from the name's extension, so the temporary ends in .mp4
        self._tmp = path.with_name(f".{path.name}.partial.mp4")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise OutputError(f"cannot write {path}: {err.strerror}") from err
        self._writer: Any = None
        self._size: tuple[int, int] | None = None
        self.frames = 0

    def add(
        self,
        image_bgr: NDArray[np.uint8],
        lanes: Sequence[Any],
        hough_lines: Sequence[NDArray[np.float64]] = (),
        corridor: NDArray[np.float32] | None = None,
    ) -> None:
        """Draw and append one frame (frames of another size are resized to the first)."""
        import cv2

        frame = draw_overlay(image_bgr, lanes, hough_lines, corridor)
        height, width = frame.shape[:2]
        if self._writer is None:
            self._size = (width, height)
            fourcc = cv2.VideoWriter_fourcc(*"mp4v")  # type: ignore[attr-defined]
            self._writer = cv2.VideoWriter(str(self._tmp), fourcc, self.fps, self._size)
            if not self._writer.isOpened():
                raise OutputError(f"cannot open a video writer for {self.path}")
        elif (width, height) != self._size:
            frame = np.asarray(cv2.resize(frame, self._size), np.uint8)
        self._writer.write(frame)
        self.frames += 1

    def close(self, ok: bool) -> Path | None:
        """Finish the file; return its path, or None when discarded or empty."""
        if self._writer is not None:
            self._writer.release()
        keep = ok and self.frames > 0 and self._tmp.is_file()
        if keep:
            self._tmp.replace(self.path)
        else:
            self._tmp.unlink(missing_ok=True)
        return self.path if keep else None
