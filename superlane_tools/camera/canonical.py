"""One canonical virtual camera: resample any drive's frames into it, map label images back.

Every fleet camera differs in focal length, pitch, roll and lens distortion. A network that
sees all of them through one virtual camera needs to learn one geometry only (UniDrive's
virtual cameras). The canonical camera shares the drive camera's optical centre and yaw, and:

* has no distortion and square pixels;
* looks along the road: pitch and roll 0 relative to the vehicle, so the horizon of a flat road
  lies on one fixed image row (:attr:`CanonicalCamera.horizon_row`) whatever the mount;
* has one focal length per input width (:data:`FOCAL_PER_WIDTH`: 400 px at 512 px wide, the
  TuSimple camera's field of view of about 65 degrees, the geometry the shipped models know);
* crops to the network's input: the rows below the horizon reach a flat-road point
  :data:`NEAR_RANGE_M` ahead of a camera mounted :data:`REFERENCE_HEIGHT_M` high (the lane
  fit's ground truth runs 5-60 m); a few rows above the horizon keep the far lane ends.

A change of orientation about the same centre is the homography ``K_c R K_d^-1`` (exact at
every depth); the camera height is a translation and stays the drive's own (a lower camera
sees a given distance nearer the horizon). Undistortion, rotation, scale and crop form one
``cv2.remap`` whose map (:func:`canonical_maps`) is computed once per drive and image size;
the inverse map takes the canonical label image back to the recording's pixels
(nearest-neighbour), so that the lane fit and every output stay in the recording's pixels.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics

FloatArray = NDArray[np.float64]
FOCAL_PER_WIDTH = 400.0 / 512.0
"""Canonical focal length per pixel of input width (400 px at 512 px: the TuSimple camera's
1000 px at 1280 px, a horizontal field of view of 65.2 degrees)."""
NEAR_RANGE_M = 5.0
"""The bottom row sees the flat road this far ahead of a camera :data:`REFERENCE_HEIGHT_M` high."""
REFERENCE_HEIGHT_M = 1.7
"""Reference mount height, metres (TuSimple 1.72 m, KITTI 1.65 m, the simulator 1.5 m)."""
BAND_ROWS_PER_WIDTH = 135.0 / 512.0
"""Rows from the horizon to the bottom row per pixel of width: ``f * h_ref / NEAR_RANGE_M``
rounded (400 * 1.7 / 5 = 136 px at 512 px wide)."""
OUTSIDE = -1.0
"""Map entry of a pixel with no counterpart (outside the other image, or behind the camera)."""


@dataclass(frozen=True)
class CanonicalCamera:
    """The canonical virtual camera's image: size, focal length and horizon row.

    Attributes:
        width: Image width in pixels (the network's input width).
        height: Image height in pixels (the network's input height).
        focal_px: Focal length in pixels (square pixels).
        horizon_row: Row of the flat road's horizon (pixel-centre coordinates), also the
            principal point's row (pitch 0).
    """

    width: int = 512
    height: int = 160
    focal_px: float = 400.0
    horizon_row: float = 24.0

    def __post_init__(self) -> None:
        if self.width < 8 or self.height < 8 or not self.focal_px > 0:
            raise CameraError(
                f"canonical camera needs >= 8x8 pixels and a positive focal length, got "
                f"{self.width}x{self.height} f={self.focal_px}"
            )
        if not 0.0 <= self.horizon_row < self.height - 1:
            raise CameraError(
                f"canonical horizon row {self.horizon_row} must lie in the image (0..{self.height})"
            )

    @classmethod
    def for_input(
        cls, width: int, height: int, near_range_m: float | None = None
    ) -> CanonicalCamera:
        """Return the canonical camera of a ``width x height`` network input.

        The focal length is :data:`FOCAL_PER_WIDTH` x width and the bottom row
        :data:`BAND_ROWS_PER_WIDTH` x width below the horizon (512x160: f 400 px, horizon row
        24; 512x288: horizon row 152, the extra rows above the horizon). With
        ``near_range_m``, the bottom row sees the flat road that far ahead of a camera
        :data:`REFERENCE_HEIGHT_M` high instead (512x224 at 3.4 m: horizon row 23): a nearer
        bottom row keeps the near field, where a lane's fit starts.
        """
        if near_range_m is not None and not near_range_m > 0:
            raise CameraError(f"canonical near range must be > 0 m, got {near_range_m}")
        band = (
            BAND_ROWS_PER_WIDTH * width
            if near_range_m is None
            else FOCAL_PER_WIDTH * width * REFERENCE_HEIGHT_M / near_range_m
        )
        return cls(width, height, FOCAL_PER_WIDTH * width, max(0.0, height - 1 - band))

    def model(self, drive: CameraModel) -> CameraModel:
        """Return the canonical camera on ``drive``'s vehicle: same centre and yaw, pitch/roll 0."""
        intr = Intrinsics(
            self.width,
            self.height,
            self.focal_px,
            self.focal_px,
            (self.width - 1) / 2.0,
            self.horizon_row,
        )
        extr: Extrinsics = replace(drive.extrinsics, pitch_rad=0.0, roll_rad=0.0)
        return CameraModel(intr, extr, name=f"canonical({drive.name})")

    def near_range_m(self, height_m: float) -> float:
        """Return the flat-road distance (m) on the bottom row for a camera ``height_m`` high."""
        return height_m * self.focal_px / (self.height - 1 - self.horizon_row)

    def to_dict(self) -> dict[str, Any]:
        """Return the plain mapping stored in a model card (``training.canonical_camera``)."""
        return {
            "width": self.width,
            "height": self.height,
            "focal_px": self.focal_px,
            "horizon_row": self.horizon_row,
        }

    @classmethod
    def from_dict(cls, data: Any) -> CanonicalCamera:
        """Build the camera from :meth:`to_dict`'s mapping.

        Raises:
            CameraError: If a field is missing or not a number.
        """
        try:
            return cls(
                int(data["width"]),
                int(data["height"]),
                float(data["focal_px"]),
                float(data["horizon_row"]),
            )
        except (KeyError, TypeError, ValueError) as err:
            raise CameraError(f"invalid canonical camera {data!r}: {err!r}") from err


def rotation_to_canonical(drive: CameraModel, canonical: CameraModel) -> FloatArray:
    """Return ``R`` taking drive optical-frame directions to canonical optical-frame ones."""
    rot: FloatArray = canonical.extrinsics.rotation.T @ drive.extrinsics.rotation
    return rot


def source_to_canonical(drive: CameraModel, canonical: CameraModel, uv: FloatArray) -> FloatArray:
    """Return the canonical pixels ``(N, 2)`` of the drive's ``(N, 2)`` (distorted) pixels.

    Exact: the package's own undistortion (Newton), a rotation and the canonical pinhole. Pixels
    whose ray points behind the canonical camera get :data:`OUTSIDE`.
    """
    xn, yn = drive.normalized(uv)
    r = rotation_to_canonical(drive, canonical)
    # R @ (x, y, 1) per pixel, written out: a (N, 3) @ (3, 3) product is ten times slower
    rx, ry, rz = (r[i, 0] * xn + r[i, 1] * yn + r[i, 2] for i in range(3))
    k = canonical.intrinsics
    front = rz > 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(front, k.fx * rx / rz + k.cx, OUTSIDE)
        v = np.where(front, k.fy * ry / rz + k.cy, OUTSIDE)
    return np.stack([u, v], axis=1)


@dataclass(frozen=True)
class CanonicalMaps:
    """The remap tables between one drive camera (at one image size) and the canonical camera.

    Attributes:
        drive: The drive's camera at the source image size.
        canonical: The canonical camera on the same vehicle.
        forward_x: ``(H_c, W_c)`` float32 source column of every canonical pixel (-1: none).
        forward_y: ``(H_c, W_c)`` float32 source row of every canonical pixel (-1: none).
        back_x: ``(H_s, W_s)`` float32 canonical column of every source pixel (-1: none).
        back_y: ``(H_s, W_s)`` float32 canonical row of every source pixel (-1: none).
    """

    drive: CameraModel
    canonical: CameraModel
    forward_x: NDArray[np.float32]
    forward_y: NDArray[np.float32]
    back_x: NDArray[np.float32]
    back_y: NDArray[np.float32]

    @property
    def source_size(self) -> tuple[int, int]:
        """``(width, height)`` of the drive's images, pixels."""
        return self.drive.width, self.drive.height

    def to_canonical(self, image: NDArray[Any], nearest: bool = False) -> NDArray[Any]:
        """Resample a source image (or label image, ``nearest``) into the canonical camera.

        Canonical pixels the source does not see are 0 (black; void for labels).
        """
        import cv2  # late: heavy import

        self._check(image, self.source_size)
        mode = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        out = cv2.remap(image, self.forward_x, self.forward_y, mode, borderMode=cv2.BORDER_CONSTANT)
        return np.asarray(out, dtype=image.dtype)

    def labels_to_source(self, labels: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Map a canonical label image back to the source pixels (nearest; unseen pixels 0)."""
        import cv2  # late: heavy import

        self._check(labels, (self.canonical.width, self.canonical.height))
        out = cv2.remap(
            labels, self.back_x, self.back_y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT
        )
        return np.asarray(out, dtype=np.uint8)

    def covered(self) -> NDArray[np.bool_]:
        """Return the ``(H_s, W_s)`` mask of source pixels the canonical image contains."""
        w, h = self.canonical.width, self.canonical.height
        bx, by = self.back_x, self.back_y
        return (bx > -0.5) & (bx < w - 0.5) & (by > -0.5) & (by < h - 0.5)

    @staticmethod
    def _check(image: NDArray[Any], size: tuple[int, int]) -> None:
        if image.shape[1::-1][:2] != size:
            raise CameraError(
                f"image is {image.shape[1]}x{image.shape[0]}, the map expects {size[0]}x{size[1]}"
            )


def _forward_maps(
    drive: CameraModel, canonical: CameraModel
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Return the source pixel of every canonical pixel: one ``initUndistortRectifyMap``."""
    import cv2  # late: heavy import

    rot = rotation_to_canonical(drive, canonical)
    k = drive.intrinsics
    size = (canonical.width, canonical.height)
    map_x, map_y = cv2.initUndistortRectifyMap(
        k.matrix, np.asarray(k.dist, np.float64), rot, canonical.intrinsics.matrix, size,
        cv2.CV_32FC1,
    )  # fmt: skip
    # Rays behind the drive camera, or (with distortion) outside the undistorted field of view
    # where the polynomial folds back into the image, have no source pixel.
    kc = canonical.intrinsics
    xc = ((np.arange(size[0], dtype=np.float64) - kc.cx) / kc.fx)[None, :]
    yc = ((np.arange(size[1], dtype=np.float64) - kc.cy) / kc.fy)[:, None]
    rt = rot.T  # canonical directions back into the drive's optical frame
    zd = rt[2, 0] * xc + rt[2, 1] * yc + rt[2, 2]
    invalid = zd <= 1e-9
    if k.has_distortion:
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = (rt[0, 0] * xc + rt[0, 1] * yc + rt[0, 2]) / zd
            yn = (rt[1, 0] * xc + rt[1, 1] * yc + rt[1, 2]) / zd
        border = _border_pixels(drive.width, drive.height)
        bx, by = drive.normalized(border)
        invalid |= (xn < bx.min()) | (xn > bx.max()) | (yn < by.min()) | (yn > by.max())
    map_x[invalid] = OUTSIDE
    map_y[invalid] = OUTSIDE
    return np.asarray(map_x, np.float32), np.asarray(map_y, np.float32)


def _border_pixels(width: int, height: int) -> FloatArray:
    us, vs = np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64)
    top = np.stack([us, np.zeros_like(us)], axis=1)
    bottom = np.stack([us, np.full_like(us, height - 1)], axis=1)
    left = np.stack([np.zeros_like(vs), vs], axis=1)
    right = np.stack([np.full_like(vs, width - 1), vs], axis=1)
    return np.concatenate([top, bottom, left, right])


def canonical_maps(drive: CameraModel, canonical: CanonicalCamera) -> CanonicalMaps:
    """Compute the forward and inverse tables of ``drive`` (at its image size): once per drive.

    Raises:
        CameraError: If the canonical camera sees nothing of the drive's image.
    """
    model = canonical.model(drive)
    fx, fy = _forward_maps(drive, model)
    grid_u, grid_v = np.meshgrid(
        np.arange(drive.width, dtype=np.float64), np.arange(drive.height, dtype=np.float64)
    )
    back = source_to_canonical(drive, model, np.stack([grid_u.ravel(), grid_v.ravel()], axis=1))
    shape = (drive.height, drive.width)
    maps = CanonicalMaps(
        drive,
        model,
        fx,
        fy,
        np.asarray(back[:, 0].reshape(shape), np.float32),
        np.asarray(back[:, 1].reshape(shape), np.float32),
    )
    if not maps.covered().any():
        raise CameraError(
            f"the canonical camera ({canonical.width}x{canonical.height}, horizon row "
            f"{canonical.horizon_row}) sees nothing of camera {drive.name!r}: check its pitch"
        )
    return maps


class CanonicalView:
    """The forward half of :class:`CanonicalMaps`: resample one camera's images (training frames).

    Cheaper than :func:`canonical_maps` (no inverse table): for frames whose camera changes from
    frame to frame (simulator datasets) or that are never mapped back.

    Args:
        drive: The camera of the images, at their size.
        canonical: The canonical camera.
    """

    def __init__(self, drive: CameraModel, canonical: CanonicalCamera) -> None:
        self.drive = drive
        self.model = canonical.model(drive)
        self.forward_x, self.forward_y = _forward_maps(drive, self.model)

    def image(self, image: NDArray[Any], nearest: bool = False) -> NDArray[Any]:
        """Return ``image`` (or a label image, ``nearest``) in the canonical camera."""
        import cv2  # late: heavy import

        CanonicalMaps._check(image, (self.drive.width, self.drive.height))
        mode = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        out = cv2.remap(image, self.forward_x, self.forward_y, mode, borderMode=cv2.BORDER_CONSTANT)
        return np.asarray(out, dtype=image.dtype)

    def points(self, uv: FloatArray) -> FloatArray:
        """Return the canonical pixels of ``(N, 2)`` image pixels (exact; unseen ones dropped)."""
        out = source_to_canonical(self.drive, self.model, uv)
        keep: FloatArray = out[(out[:, 0] != OUTSIDE) | (out[:, 1] != OUTSIDE)]
        return keep
