"""Camera geometry: pinhole model, inverse perspective mapping, slope compensation, profiles."""

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics

__all__ = ["CameraError", "CameraModel", "Extrinsics", "Intrinsics"]
