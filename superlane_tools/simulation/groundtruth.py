"""Ground truth of a simulated frame: lane model fits, TuSimple lane points, the Parquet schema.

Lane model (vehicle frame, metres): every visible line ``i`` is ``y = a0_i + a1 x + a2 x^2``
with a shared heading ``a1`` and curvature ``2 a2`` (1/m), fitted by least squares to the true
line centres over ``5 <= x <= 60`` m. The road slope ``b`` is the least-squares fit of the road
surface height ``z = b x`` over the same range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.road import line_points
from superlane_tools.simulation.scene import LineStyle, RoadProfile
from superlane_tools.simulation.world import FrameWorld

FloatArray = NDArray[np.float64]

FIT_RANGE_M = (5.0, 60.0)
"""Forward range of the lane-model fit, metres."""
TUSIMPLE_ROWS_720 = tuple(range(160, 720, 10))
"""TuSimple ``h_samples`` for a 720-row image."""
NO_POINT = -2
"""TuSimple marker for rows where a lane has no visible point."""

_OCCLUDING = np.zeros(256, dtype=bool)
for _name in ("sky", "vehicle", "person", "building_wall_fence", "vegetation", "pole_sign_utility"):
    _OCCLUDING[LEAF_IDS[_name]] = True


@dataclass(frozen=True)
class LaneTruth:
    """True lane geometry of one frame.

    Attributes:
        slots: Slot of each visible line (0 = leftmost line of the road), left to right.
        profile_index: Index of each line in ``FrameScene.road.lines``.
        offsets_m: ``a0`` of each line, metres, left positive.
        heading_rad: Shared ``a1`` (slope dy/dx, radians for small angles).
        curvature: Shared ``2 a2``, 1/m, left positive.
        cubic: ``(n, 4)`` per-line cubic ``c0..c3`` fitted over 0-60 m (left-positive).
        view_range_m: Farthest forward distance of each line within the profile, metres.
        colors: Colour of each line.
        styles: Style of each line.
        widths_m: Paint width of each line, metres.
        slope: Road slope ``b`` (dz/dx).
        ego_left: Position of the ego lane's left line in these lists (-1 if not visible).
        ego_right: Position of the ego lane's right line in these lists (-1 if not visible).
    """

    slots: tuple[int, ...]
    profile_index: tuple[int, ...]
    offsets_m: tuple[float, ...]
    heading_rad: float
    curvature: float
    cubic: FloatArray
    view_range_m: tuple[float, ...]
    colors: tuple[str, ...]
    styles: tuple[str, ...]
    widths_m: tuple[float, ...]
    slope: float
    ego_left: int
    ego_right: int


def _dense_s(profile: RoadProfile, step_m: float = 0.5) -> FloatArray:
    out: FloatArray = np.arange(float(profile.s_m[0]), float(profile.s_m[-1]), step_m)
    return out


def lane_truth(fw: FrameWorld) -> LaneTruth:
    """Fit the shared lane model and per-line cubics to the true lines of a frame."""
    profile = fw.scene.road
    s_dense = _dense_s(profile)
    lo, hi = FIT_RANGE_M
    per_line: list[tuple[int, FloatArray, FloatArray, FloatArray]] = []
    for k, line in enumerate(profile.lines):
        _, pts = line_points(profile, line, s_dense)
        if len(pts) == 0:
            continue
        per_line.append((k, pts[:, 0], pts[:, 1], pts[:, 2]))
    rows: list[tuple[int, FloatArray, FloatArray]] = []
    for k, x, y, _ in per_line:
        sel = (x >= lo) & (x <= hi)
        if sel.sum() >= 5:
            rows.append((k, x[sel], y[sel]))
    # a piece of the same slot may appear twice (e.g. a line resumes after an intersection):
    # keep the piece with most fit points per slot
    best: dict[int, tuple[int, FloatArray, FloatArray]] = {}
    for k, x, y in rows:
        slot = fw.line_slots[k]
        if slot not in best or len(x) > len(best[slot][1]):
            best[slot] = (k, x, y)
    chosen = [best[slot] for slot in sorted(best)]
    n = len(chosen)
    a0: list[float] = []
    a1 = a2 = 0.0
    if n:
        n_pts = sum(len(x) for _, x, _ in chosen)
        design = np.zeros((n_pts, n + 2))
        target = np.zeros(n_pts)
        row = 0
        for j, (_, x, y) in enumerate(chosen):
            m = len(x)
            design[row : row + m, j] = 1.0
            design[row : row + m, n] = x
            design[row : row + m, n + 1] = x * x
            target[row : row + m] = y
            row += m
        sol = np.linalg.lstsq(design, target, rcond=None)[0]
        a0 = [float(v) for v in sol[:n]]
        a1, a2 = float(sol[n]), float(sol[n + 1])
    cubic = np.zeros((n, 4))
    view: list[float] = []
    for j, (k, _, _) in enumerate(chosen):
        _, x, y, _ = next(p for p in per_line if p[0] == k)
        sel = (x >= 0.0) & (x <= hi)
        if sel.sum() >= 6:
            cubic[j] = np.polynomial.polynomial.polyfit(x[sel], y[sel], 3)
        view.append(float(x.max()))
    zsel = (profile.x_m >= lo) & (profile.x_m <= hi)
    xz, zz = profile.x_m[zsel], profile.z_m[zsel]
    slope = float(np.dot(xz, zz) / np.dot(xz, xz)) if len(xz) else 0.0
    idx = [k for k, _, _ in chosen]
    left = idx.index(fw.scene.ego_left_line) if fw.scene.ego_left_line in idx else -1
    right = idx.index(fw.scene.ego_right_line) if fw.scene.ego_right_line in idx else -1
    lines = [profile.lines[k] for k in idx]
    return LaneTruth(
        slots=tuple(fw.line_slots[k] for k in idx),
        profile_index=tuple(idx),
        offsets_m=tuple(a0),
        heading_rad=a1,
        curvature=2.0 * a2,
        cubic=cubic,
        view_range_m=tuple(view),
        colors=tuple(str(ln.color) for ln in lines),
        styles=tuple(str(ln.style) for ln in lines),
        widths_m=tuple(float(ln.width_m) for ln in lines),
        slope=slope,
        ego_left=left,
        ego_right=right,
    )


def h_samples(height: int) -> list[int]:
    """Return TuSimple ``h_samples`` (rows 160:720:10) scaled to an image ``height`` pixels."""
    return [round(r * height / 720) for r in TUSIMPLE_ROWS_720]


def tusimple_lanes(
    profile: RoadProfile,
    camera: CameraModel,
    line_indices: tuple[int, ...],
    rows: list[int],
    labels: NDArray[np.uint8] | None = None,
) -> list[list[int]]:
    """Project true lines through the camera and read their column at each TuSimple row.

    A line counts as continuous through dash gaps (TuSimple annotates whole lanes). Points
    hidden behind a crest (not a new minimum of the image row along the line), outside the
    image, or -- when ``labels`` is given -- on an occluding class (vehicle, vegetation, sky...)
    get :data:`NO_POINT`.

    Args:
        profile: Road profile of the frame.
        camera: The frame's camera.
        line_indices: Indices into ``profile.lines``, left to right.
        rows: Image rows (``h_samples``).
        labels: Optional leaf-id label image of the frame.

    Returns:
        One list of columns (pixels, rounded) per line, ``len(rows)`` each.
    """
    width, height = camera.width, camera.height
    s_dense = _dense_s(profile, 0.25)
    out: list[list[int]] = []
    rows_arr = np.asarray(rows, dtype=np.float64)
    for k in line_indices:
        line = profile.lines[k]
        _, pts = line_points(profile, line, s_dense)
        result = np.full(len(rows), NO_POINT, dtype=np.int64)
        ahead = pts[:, 0] > 1.0
        pts = pts[ahead]
        if len(pts) >= 2:
            uv, front = camera.project(pts)
            uv, pts = uv[front], pts[front]
            v = uv[:, 1]
            runmin = np.minimum.accumulate(v)
            vis = v <= runmin + 1e-9
            # previous visible point of each visible point must be adjacent (no hidden stretch)
            keep = np.flatnonzero(vis)
            for j, row in enumerate(rows_arr):
                # first crossing of the row between consecutive visible samples
                va, vb = v[keep[:-1]], v[keep[1:]]
                adjacent = np.diff(keep) == 1
                hit = np.flatnonzero(adjacent & (va >= row) & (vb < row))
                if not len(hit):
                    continue
                i0, i1 = keep[hit[0]], keep[hit[0] + 1]
                w = (v[i0] - row) / (v[i0] - v[i1])
                u = uv[i0, 0] + w * (uv[i1, 0] - uv[i0, 0])
                if not 0 <= u <= width - 1 or row > height - 1:
                    continue
                if labels is not None and _OCCLUDING[labels[int(row), round(u)]]:
                    continue
                result[j] = round(u)
        out.append([int(c) for c in result])
    return out


def painted_mask(
    line_style: str, dash_m: float, gap_m: float, phase_m: float, s_m: FloatArray
) -> NDArray[np.bool_]:
    """Return which arc lengths ``s_m`` carry paint (always True except in dash gaps)."""
    if line_style != LineStyle.DASHED or dash_m <= 0:
        return np.ones(len(s_m), dtype=bool)
    out: NDArray[np.bool_] = np.mod(s_m - phase_m, dash_m + gap_m) < dash_m
    return out


GT_SCHEMA = pa.schema(
    [
        ("t_ns", pa.int64()),
        ("frame_index", pa.int32()),
        ("scenario", pa.string()),
        ("tags", pa.list_(pa.string())),
        ("daylight", pa.float32()),
        ("wet", pa.float32()),
        ("rain", pa.float32()),
        ("fog", pa.float32()),
        ("glare", pa.float32()),
        ("tunnel", pa.bool_()),
        ("tar_seams", pa.float32()),
        ("wear", pa.float32()),
        ("speed_mps", pa.float64()),
        ("yaw_rate_rps", pa.float64()),
        ("path_curvature", pa.float64()),
        ("east_m", pa.float64()),
        ("north_m", pa.float64()),
        ("up_m", pa.float64()),
        ("heading_rad", pa.float64()),
        ("pitch_rad", pa.float64()),
        ("road_s_m", pa.float64()),
        ("lateral_m", pa.float64()),
        ("ego_lane_index", pa.int32()),
        ("ego_left_line", pa.int32()),
        ("ego_right_line", pa.int32()),
        ("line_slot", pa.list_(pa.int32())),
        ("line_offset_m", pa.list_(pa.float64())),
        ("line_color", pa.list_(pa.string())),
        ("line_style", pa.list_(pa.string())),
        ("line_width_m", pa.list_(pa.float64())),
        ("line_view_range_m", pa.list_(pa.float64())),
        ("lane_heading_rad", pa.float64()),
        ("lane_curvature", pa.float64()),
        ("road_slope", pa.float64()),
        ("corridor_width_m", pa.float64()),
        ("corridor_length_m", pa.float64()),
        ("lead_gap_m", pa.float64()),
    ]
)
"""Schema of ``<stem>.gt.parquet``: one row per camera frame (see docs/simulator.md)."""


def condition_tags(fw: FrameWorld) -> list[str]:
    """Return short condition tags of a frame (scenario name first)."""
    c = fw.scene.conditions
    tags = [c.name]
    checks = (
        ("night", c.daylight < 0.2),
        ("tunnel", c.tunnel),
        ("wet", c.wet >= 0.3),
        ("rain", c.rain >= 0.3),
        ("glare", c.glare >= 0.3),
        ("fog", c.fog >= 0.3),
        ("tar_seams", c.tar_seams >= 0.3),
        ("faded_lines", fw.scene.road.lines[0].wear >= 0.3 if fw.scene.road.lines else False),
    )
    tags += [name for name, on in checks if on and name != c.name]
    return tags


def gt_row(fw: FrameWorld, truth: LaneTruth, frame_index: int) -> dict[str, object]:
    """Return one ground-truth row (a mapping of :data:`GT_SCHEMA` columns) for a frame."""
    c = fw.scene.conditions
    st = fw.state
    wear = fw.scene.road.lines[0].wear if fw.scene.road.lines else 0.0
    return {
        "t_ns": fw.scene.t_ns,
        "frame_index": frame_index,
        "scenario": c.name,
        "tags": condition_tags(fw),
        "daylight": c.daylight,
        "wet": c.wet,
        "rain": c.rain,
        "fog": c.fog,
        "glare": c.glare,
        "tunnel": c.tunnel,
        "tar_seams": c.tar_seams,
        "wear": wear,
        "speed_mps": st.speed_mps,
        "yaw_rate_rps": st.yaw_rate_rps,
        "path_curvature": st.curvature,
        "east_m": st.pose.x_m,
        "north_m": st.pose.y_m,
        "up_m": st.pose.z_m,
        "heading_rad": st.pose.heading_rad,
        "pitch_rad": st.pose.pitch_rad,
        "road_s_m": st.pose.s_m,
        "lateral_m": st.lateral_m,
        "ego_lane_index": fw.lane.index,
        "ego_left_line": truth.ego_left,
        "ego_right_line": truth.ego_right,
        "line_slot": list(truth.slots),
        "line_offset_m": list(truth.offsets_m),
        "line_color": list(truth.colors),
        "line_style": list(truth.styles),
        "line_width_m": list(truth.widths_m),
        "line_view_range_m": list(truth.view_range_m),
        "lane_heading_rad": truth.heading_rad,
        "lane_curvature": truth.curvature,
        "road_slope": truth.slope,
        "corridor_width_m": fw.lane.width_m,
        "corridor_length_m": fw.scene.corridor_length_m,
        "lead_gap_m": fw.lead_gap_m,
    }
