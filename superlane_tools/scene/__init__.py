"""Scene understanding: segmentation backends (classical, ONNX) producing leaf-id label images."""

from superlane_tools.scene.backend import SegmentationBackend, check_image
from superlane_tools.scene.backends import backend_from_name, known_backends
from superlane_tools.scene.classical import (
    ClassicalExtractor,
    ClassicalParams,
    RowGeometry,
    nominal_camera,
    row_geometry,
)
from superlane_tools.scene.errors import BackendUnavailableError, SceneError
from superlane_tools.scene.image_folder import (
    InputFrame,
    SegmentedImage,
    classes_yaml,
    folder_frames,
    list_images,
    overlay,
    segment_folder,
    segment_images,
)

__all__ = [
    "BackendUnavailableError",
    "ClassicalExtractor",
    "ClassicalParams",
    "InputFrame",
    "RowGeometry",
    "SceneError",
    "SegmentationBackend",
    "SegmentedImage",
    "backend_from_name",
    "check_image",
    "classes_yaml",
    "folder_frames",
    "known_backends",
    "list_images",
    "nominal_camera",
    "overlay",
    "row_geometry",
    "segment_folder",
    "segment_images",
]
