"""Camera geometry: pinhole model, inverse perspective mapping, slope compensation, profiles."""

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.ipm import (
    BevGrid,
    bev_maps,
    ground_to_image,
    image_to_ground,
    warp_to_bev,
)
from superlane_tools.camera.kitti import (
    KITTI_CAMERA_HEIGHT_M,
    KittiCalib,
    camera2_model,
    kitti_camera,
    parse_kitti_calib_text,
    read_kitti_calib,
)
from superlane_tools.camera.lane_calibration import (
    LaneCalibration,
    LaneCalibrationParams,
    estimate_camera_from_lanes,
    vanishing_point,
)
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.camera.profiles import (
    camera_from_yaml,
    camera_to_yaml,
    list_profiles,
    load_camera,
)
from superlane_tools.camera.ros import from_camera_info
from superlane_tools.camera.slope import (
    LinearRoad,
    QuadraticRoad,
    RoadModel,
    compensate,
    compensate_linear,
    compensate_points,
    ray_scale_numeric,
    road_height,
)

__all__ = [
    "KITTI_CAMERA_HEIGHT_M",
    "BevGrid",
    "CameraError",
    "CameraModel",
    "Extrinsics",
    "Intrinsics",
    "KittiCalib",
    "LaneCalibration",
    "LaneCalibrationParams",
    "LinearRoad",
    "QuadraticRoad",
    "RoadModel",
    "bev_maps",
    "camera2_model",
    "camera_from_yaml",
    "camera_to_yaml",
    "compensate",
    "compensate_linear",
    "compensate_points",
    "estimate_camera_from_lanes",
    "from_camera_info",
    "ground_to_image",
    "image_to_ground",
    "kitti_camera",
    "list_profiles",
    "load_camera",
    "parse_kitti_calib_text",
    "ray_scale_numeric",
    "read_kitti_calib",
    "road_height",
    "vanishing_point",
    "warp_to_bev",
]
