"""What the renderer draws: one frame's scene in the vehicle frame (the world/render contract).

The world model (``world.py``, ``motion.py``) produces a :class:`FrameScene` per camera frame;
the renderer (``render/``) turns it into an image, a leaf-id label image and an ego-corridor
mask. Everything here is in the **vehicle frame** of that frame (see ``camera/model.py``:
x forward, y left, z up, metres, origin on the road surface below the camera), so the
renderer never needs the world map.

Road coordinates: ``s`` is arc length along the road reference line from the world's start
(metres; stable from frame to frame, so dashes and textures stay fixed to the road), ``l`` is
the lateral offset from the reference line, measured in the road plane, left positive.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel

FloatArray = NDArray[np.float64]


class LineStyle(StrEnum):
    """Painted line style."""

    SOLID = "solid"
    DASHED = "dashed"
    DOUBLE = "double"  # two solid lines ~0.15 m apart (e.g. double yellow)


class LineColor(StrEnum):
    """Painted line colour."""

    WHITE = "white"
    YELLOW = "yellow"


@dataclass(frozen=True)
class LaneLine:
    """One painted longitudinal line.

    Attributes:
        offset_m: Lateral position of the line centre from the reference line at ``s`` before any
            taper, metres, left positive.
        style: Solid, dashed or double.
        color: White or yellow.
        width_m: Paint width, metres (each stroke of a double line).
        dash_m: Dash length for dashed lines, metres.
        gap_m: Gap length for dashed lines, metres.
        phase_m: Arc length ``s`` at which a dash starts, metres.
        wear: 0 (fresh paint) to 1 (invisible): fraction of paint missing, for faded lines.
        taper_start_s_m: Arc length where a lateral taper (merge/split) begins; NaN for none.
        taper_length_m: Length of the taper, metres.
        taper_delta_m: Lateral change over the taper, metres (left positive).
        start_s_m: Arc length where the line begins (-inf for always).
        end_s_m: Arc length where the line ends (+inf for always).
    """

    offset_m: float
    style: LineStyle = LineStyle.SOLID
    color: LineColor = LineColor.WHITE
    width_m: float = 0.15
    dash_m: float = 3.0
    gap_m: float = 9.0
    phase_m: float = 0.0
    wear: float = 0.0
    taper_start_s_m: float = float("nan")
    taper_length_m: float = 0.0
    taper_delta_m: float = 0.0
    start_s_m: float = float("-inf")
    end_s_m: float = float("inf")

    def offset_at(self, s_m: FloatArray) -> FloatArray:
        """Return the lateral offset (m, left positive) of the line centre at ``s_m``."""
        s = np.asarray(s_m, dtype=np.float64)
        if np.isnan(self.taper_start_s_m) or self.taper_length_m <= 0:
            return np.full_like(s, self.offset_m)
        frac = np.clip((s - self.taper_start_s_m) / self.taper_length_m, 0.0, 1.0)
        smooth = frac * frac * (3.0 - 2.0 * frac)
        out: FloatArray = self.offset_m + self.taper_delta_m * smooth
        return out


@dataclass(frozen=True)
class RoadProfile:
    """The road ahead (and a little behind) in the vehicle frame, sampled along the reference line.

    Sample arrays all have shape ``(K,)``, ordered by increasing ``s_m``; ``x_m`` increases
    monotonically (the visible road never turns through 90 degrees).

    Attributes:
        s_m: Arc length of each sample along the reference line (world coordinate), metres.
        x_m: Forward position of the reference line in the vehicle frame, metres.
        y_m: Lateral position of the reference line, metres, left positive.
        z_m: Height of the road surface at the reference line, metres (0 under the vehicle).
        heading_rad: Direction of the reference line in the vehicle frame, radians, left positive.
        lines: Painted longitudinal lines.
        left_edge_m: Lateral position of the left edge of the paved surface, metres (> 0).
        right_edge_m: Lateral position of the right edge of the paved surface, metres (< 0).
        shoulder_m: Width of the paved shoulder outside the outermost lines, metres.
        curb_height_m: Curb height at the paved edges, metres (0 = no curb, terrain follows).
        sidewalk_m: Sidewalk width beyond each curb, metres (0 = none).
        surface: ``asphalt`` or ``concrete``.
        crosswalks_s_m: ``(start, stop)`` arc-length ranges painted as zebra crosswalks.
        stop_lines_s_m: Arc lengths of stop lines across the ego direction's lanes.
    """

    s_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    z_m: FloatArray
    heading_rad: FloatArray
    lines: tuple[LaneLine, ...]
    left_edge_m: float
    right_edge_m: float
    shoulder_m: float = 0.5
    curb_height_m: float = 0.0
    sidewalk_m: float = 0.0
    surface: str = "asphalt"
    crosswalks_s_m: tuple[tuple[float, float], ...] = ()
    stop_lines_s_m: tuple[float, ...] = ()


@dataclass(frozen=True)
class SceneObject:
    """An object above the road, drawn as a box (or the renderer's shape for its kind).

    Attributes:
        kind: Hierarchy leaf name it is labelled as: ``vehicle``, ``person``,
            ``building_wall_fence`` (buildings, guard rails, walls), ``vegetation``,
            ``pole_sign_utility``.
        x_m: Forward position of the bottom centre in the vehicle frame, metres.
        y_m: Lateral position of the bottom centre, metres, left positive.
        z_m: Height of the bottom centre, metres.
        length_m: Extent along its own heading, metres.
        width_m: Extent across, metres.
        height_m: Extent up, metres.
        yaw_rad: Heading in the vehicle frame, radians, left positive.
        color_bgr: Base colour.
        style: Free-form shape hint for the renderer (``car``, ``truck``, ``guard_rail``,
            ``tree``, ``bush``, ``sign``, ``pole``, ``building``...).
    """

    kind: str
    x_m: float
    y_m: float
    z_m: float
    length_m: float
    width_m: float
    height_m: float
    yaw_rad: float = 0.0
    color_bgr: tuple[int, int, int] = (128, 128, 128)
    style: str = ""


@dataclass(frozen=True)
class Conditions:
    """Lighting, weather and sensor effects for one frame (all intensities 0..1).

    Attributes:
        name: Scenario / condition tag.
        daylight: 1 bright day, ~0.3 dusk, ~0.05 night (headlights only).
        sun_elevation_deg: Sun elevation above the horizon, degrees.
        sun_azimuth_rad: Sun direction from the forward axis, radians, left positive.
        glare: Low-sun glare / lens flare strength.
        wet: Wet-road reflections strength.
        rain: Rain streaks, droplets and spray strength.
        fog: Atmospheric haze strength.
        tunnel: Inside a tunnel (walls and ceiling, artificial lights).
        tar_seams: Density of dark sealant lines on the road.
        cracks: Density of cracks and patches.
        exposure: Exposure multiplier (1 nominal).
        noise_sigma: Sensor noise standard deviation in 8-bit grey levels.
        motion_blur_px: Horizontal/vertical motion blur length, pixels.
        jpeg_quality: JPEG quality for the recorded frame (1-100).
        randomize: Domain randomisation strength for training data (0 = realistic defaults).
    """

    name: str = "highway_straight"
    daylight: float = 1.0
    sun_elevation_deg: float = 45.0
    sun_azimuth_rad: float = 0.0
    glare: float = 0.0
    wet: float = 0.0
    rain: float = 0.0
    fog: float = 0.0
    tunnel: bool = False
    tar_seams: float = 0.0
    cracks: float = 0.2
    exposure: float = 1.0
    noise_sigma: float = 2.0
    motion_blur_px: float = 0.0
    jpeg_quality: int = 90
    randomize: float = 0.0


@dataclass(frozen=True)
class FrameScene:
    """Everything needed to render one camera frame.

    Attributes:
        t_ns: Frame time, integer nanoseconds.
        camera: Camera model (intrinsics + pose in the vehicle frame).
        road: The road ahead in the vehicle frame.
        objects: Objects to draw (vehicles, buildings, vegetation, poles, signs, rails...).
        conditions: Lighting, weather and sensor effects.
        ego_left_line: Index into ``road.lines`` of the ego lane's left line.
        ego_right_line: Index into ``road.lines`` of the ego lane's right line.
        corridor_length_m: Forward extent of the ego corridor (distance to the preceding
            vehicle's rear, or the view limit), metres.
        world_seed: Seed of the world's textures (constant over a drive).
        frame_seed: Seed of this frame's random effects (noise, rain drops).
    """

    t_ns: int
    camera: CameraModel
    road: RoadProfile
    objects: tuple[SceneObject, ...] = ()
    conditions: Conditions = field(default_factory=Conditions)
    ego_left_line: int = 0
    ego_right_line: int = 1
    corridor_length_m: float = 100.0
    world_seed: int = 0
    frame_seed: int = 0


@dataclass(frozen=True)
class RenderedFrame:
    """The renderer's output for one :class:`FrameScene`.

    Attributes:
        image_bgr: ``(H, W, 3)`` uint8 colour image (before JPEG compression).
        labels: ``(H, W)`` uint8 leaf ids of ``superlane_tools.hierarchy`` (0 = void).
        corridor: ``(H, W)`` bool ego-corridor mask (ego lane up to the preceding vehicle).
    """

    image_bgr: NDArray[np.uint8]
    labels: NDArray[np.uint8]
    corridor: NDArray[np.bool_]
