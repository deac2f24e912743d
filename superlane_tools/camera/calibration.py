"""Intrinsics and distortion from chessboard photos (OpenCV), written as a camera profile."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics

MIN_VIEWS = 3
"""Fewest chessboard views a calibration is attempted with."""


@dataclass(frozen=True)
class ChessboardCalibration:
    """Result of a chessboard calibration.

    Attributes:
        intrinsics: Pinhole matrix and plumb-bob distortion (k1 k2 p1 p2 k3), pixels.
        rms_px: RMS reprojection error over all corners of the used views, pixels.
        per_view_rms_px: RMS reprojection error per used view, pixels, in ``used`` order.
        used: Images whose board was found.
        rejected: Images without a complete board (or of another size), with the reason.
        board: Inner corners per row and column.
        square_m: Square size, metres (scales only the board poses, not the intrinsics).
    """

    intrinsics: Intrinsics
    rms_px: float
    per_view_rms_px: tuple[float, ...]
    used: tuple[Path, ...]
    rejected: tuple[tuple[Path, str], ...]
    board: tuple[int, int]
    square_m: float

    def summary(self) -> dict[str, Any]:
        """Return a YAML-ready mapping of the calibration's quality and inputs."""
        return {
            "method": "opencv chessboard (calibrateCamera)",
            "board": f"{self.board[0]}x{self.board[1]}",
            "square_m": self.square_m,
            "reprojection_rms_px": round(self.rms_px, 4),
            "views_used": len(self.used),
            "views_rejected": [p.name for p, _ in self.rejected],
        }


def parse_board(text: str) -> tuple[int, int]:
    """Parse ``9x6`` (inner corners per row x per column).

    Raises:
        CameraError: If it is not two integers >= 2.
    """
    try:
        cols, rows = (int(v) for v in text.lower().split("x"))
    except ValueError as err:
        raise CameraError(f"board must look like 9x6 (inner corners), got {text!r}") from err
    if cols < 2 or rows < 2:
        raise CameraError(f"a board needs at least 2x2 inner corners, got {text!r}")
    return cols, rows


def calibrate_chessboard(
    images: Sequence[Path], board: tuple[int, int] = (9, 6), square_m: float = 1.0
) -> ChessboardCalibration:
    """Find the board's inner corners in each photo and calibrate the camera.

    Corners are refined to sub-pixel accuracy; views where the whole board is not found (a
    corner cut off by the frame, as in some of any real set) are listed as rejected.

    Args:
        images: Photos of a flat chessboard taken with one camera at one resolution.
        board: Inner corners per row and per column (a 10x7-square board has 9x6).
        square_m: Side of one square, metres.

    Raises:
        CameraError: If fewer than :data:`MIN_VIEWS` views show the whole board.
    """
    import cv2

    cols, rows = board
    grid = np.zeros((cols * rows, 3), np.float32)
    grid[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    object_points: list[np.ndarray] = []
    image_points: list[np.ndarray] = []
    used: list[Path] = []
    rejected: list[tuple[Path, str]] = []
    size: tuple[int, int] | None = None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    for path in images:
        gray = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if gray is None:
            rejected.append((path, "not a readable image"))
            continue
        this = (int(gray.shape[1]), int(gray.shape[0]))
        if size is None:
            size = this
        if this != size:
            rejected.append((path, f"size differs from the first photo's {size[0]}x{size[1]}"))
            continue
        found, corners = cv2.findChessboardCorners(gray, (cols, rows))
        if not found:
            rejected.append((path, f"no complete {cols}x{rows} board found"))
            continue
        corners = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), criteria)
        object_points.append(grid)
        image_points.append(corners)
        used.append(path)
    if size is None or len(used) < MIN_VIEWS:
        raise CameraError(
            f"only {len(used)} of {len(images)} images show a complete {cols}x{rows} board; "
            f"need at least {MIN_VIEWS}"
        )
    rms, k, dist, rvecs, tvecs = cv2.calibrateCamera(object_points, image_points, size, None, None)
    per_view = []
    for obj, img, rvec, tvec in zip(object_points, image_points, rvecs, tvecs, strict=True):
        projected, _ = cv2.projectPoints(obj, rvec, tvec, k, dist)
        err = projected.reshape(-1, 2) - img.reshape(-1, 2)
        per_view.append(float(math.sqrt(float(np.mean(np.sum(err * err, axis=1))))))
    d = [float(v) for v in np.asarray(dist).reshape(-1)[:5]]
    d += [0.0] * (5 - len(d))
    intrinsics = Intrinsics(
        width=size[0],
        height=size[1],
        fx=float(k[0, 0]),
        fy=float(k[1, 1]),
        cx=float(k[0, 2]),
        cy=float(k[1, 2]),
        dist=(d[0], d[1], d[2], d[3], d[4]),
    )
    return ChessboardCalibration(
        intrinsics, float(rms), tuple(per_view), tuple(used), tuple(rejected), board, square_m
    )


def calibrated_camera(
    calibration: ChessboardCalibration, extrinsics: Extrinsics, name: str
) -> CameraModel:
    """Return the camera model of a calibration with the given mounting pose."""
    return CameraModel(calibration.intrinsics, extrinsics, name=name)


def undistort_image(camera: CameraModel, image: np.ndarray) -> np.ndarray:
    """Return ``image`` with the camera's lens distortion removed (same K, same size)."""
    import cv2

    k = camera.intrinsics
    if not k.has_distortion:
        return image
    out: np.ndarray = cv2.undistort(image, k.matrix, np.asarray(k.dist, dtype=np.float64))
    return out
