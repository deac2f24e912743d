"""`slt camera`: list and show camera profiles, convert KITTI files, calibrate from photos.

``slt camera estimate`` is its own command (:mod:`superlane_tools.commands.camera_estimate`).
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.commands.options import OutputGuard
from superlane_tools.errors import UsageError
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from superlane_tools.camera.model import CameraModel

IMAGE_SUFFIXES = frozenset({".jpg", ".jpeg", ".png"})
"""The chessboard photos ``calibrate`` reads from a folder."""


def profiles() -> list[tuple[str, CameraModel]]:
    """Return every bundled camera profile with its name (``slt camera list``)."""
    from superlane_tools.camera import list_profiles, load_camera

    return [(name, load_camera(name)) for name in list_profiles()]


def show(camera: str) -> str:
    """Return a camera profile as YAML, with the horizon and the field of view as comments."""
    from superlane_tools.camera import camera_to_yaml, load_camera

    cam = load_camera(camera)
    k = cam.intrinsics
    hfov = math.degrees(2.0 * math.atan(k.width / (2.0 * k.fx)))
    vfov = math.degrees(2.0 * math.atan(k.height / (2.0 * k.fy)))
    comment = (
        f"horizon row: {cam.horizon_row():.1f} px\n"
        f"field of view: {hfov:.1f} x {vfov:.1f} deg (undistorted)"
    )
    return camera_to_yaml(cam, comment=comment)


@dataclass(frozen=True)
class ProfileOutput:
    """A profile's YAML, and the file it was written to (None: print it)."""

    text: str
    written: Path | None


def _write(text: str, out: Path | None, guard: OutputGuard) -> ProfileOutput:
    from superlane_tools.reporting import write_text_atomic

    if out is not None:
        with guard:
            write_text_atomic(out, text)
    return ProfileOutput(text, out)


@dataclass(frozen=True)
class KittiParams:
    """What ``slt camera from-kitti`` was asked (see its options)."""

    calib: Path
    width: int = 1242
    height: int = 375
    camera_height_m: float = 1.65
    name: str = "kitti"
    out: Path | None = None
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def from_kitti(params: KittiParams) -> ProfileOutput:
    """Convert a KITTI calibration file into a camera-2 profile; write it to ``out`` if given."""
    from superlane_tools.camera import camera_to_yaml, kitti_camera

    p = params
    cam = kitti_camera(p.calib, p.width, p.height, p.camera_height_m, p.name)
    comment = (
        f"KITTI camera 2 from {p.calib.name}: intrinsics from P2, angles from "
        f"R0_rect @ Tr_velo_to_cam,\nheight {p.camera_height_m:g} m (KITTI mount height). "
        f"Written by: {p.command}"
    )
    return _write(camera_to_yaml(cam, comment=comment), p.out, p.output_guard)


def check_board(value: str) -> None:
    """Parse a ``--board COLSxROWS`` value; raise its ``SltError`` if malformed."""
    from superlane_tools.camera.calibration import parse_board

    parse_board(value)


@dataclass(frozen=True)
class CalibrateParams:
    """What ``slt camera calibrate`` was asked (see its options)."""

    images: list[Path]
    board: str = "9x6"
    square_m: float = 0.025
    height_m: float = 1.3
    pitch_deg: float = 0.0
    name: str = "calibrated"
    out: Path | None = None
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


@dataclass(frozen=True)
class CalibrateOutput:
    """The calibrated profile, its RMS reprojection error, the views used and the rejected."""

    profile: ProfileOutput
    rms_px: float
    views: int
    rejected: list[Skipped]


def _image_list(images: list[Path]) -> list[Path]:
    out: list[Path] = []
    for path in images:
        if path.is_dir():
            out.extend(sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES))
        else:
            out.append(path)
    return out


def calibrate(params: CalibrateParams) -> CalibrateOutput:
    """Calibrate intrinsics and distortion from chessboard photos (OpenCV) into a profile.

    Raises:
        UsageError: If no image is given.
    """
    import yaml

    from superlane_tools.camera import camera_to_yaml
    from superlane_tools.camera.calibration import calibrate_chessboard, parse_board
    from superlane_tools.camera.model import CameraModel, Extrinsics

    p = params
    paths = _image_list(p.images)
    if not paths:
        raise UsageError("no images given (JPEG or PNG files, or folders of them)")
    result = calibrate_chessboard(paths, parse_board(p.board), p.square_m)
    cam = CameraModel(
        result.intrinsics, Extrinsics(p.height_m, math.radians(p.pitch_deg)), name=p.name
    )
    comment = (
        f"Calibrated from {len(result.used)} of {len(paths)} chessboard photos: "
        f"RMS reprojection error {result.rms_px:.3f} px.\n"
        f"Extrinsics are assumed (height {p.height_m:g} m, pitch {p.pitch_deg:g} deg): "
        "run `slt camera estimate` on a recording to estimate them.\n"
        f"Written by: {p.command}"
    )
    text = camera_to_yaml(cam, comment=comment) + yaml.safe_dump(
        {"calibration": result.summary()}, sort_keys=False
    )
    profile = _write(text, p.out, p.output_guard)
    names: dict[str, list[str]] = {}
    for path, reason in result.rejected:
        names.setdefault(f"photos, {reason}", []).append(path.name)
    lost = [Skipped(kind, ", ".join(photos), len(photos)) for kind, photos in names.items()]
    return CalibrateOutput(profile, result.rms_px, len(result.used), lost)
