"""Self-contained example scenes (straight, curve, hill) for tests, benchmarks and docs."""

from __future__ import annotations

import numpy as np

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.simulation.scene import (
    Conditions,
    FrameScene,
    LaneLine,
    LineColor,
    LineStyle,
    RoadProfile,
    SceneObject,
)

#: The simulator's default camera: 1280x720, f = 1000 px, 1.5 m high, pitched 0.06 rad down.
DEFAULT_CAMERA = CameraModel(
    Intrinsics(1280, 720, 1000.0, 1000.0, 639.5, 359.5),
    Extrinsics(height_m=1.5, pitch_rad=0.06),
    name="sim_default",
)


def reference_line(
    s0_m: float,
    curvature_1pm: float = 0.0,
    crest_at_m: float = float("nan"),
    grade: float = 0.0,
    crest_length_m: float = 80.0,
    behind_m: float = 10.0,
    ahead_m: float = 300.0,
    step_m: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(s, x, y, z, heading)`` of a constant-curvature road with an optional crest.

    Args:
        s0_m: Arc length of the vehicle position.
        curvature_1pm: Curvature, 1/m, left positive.
        crest_at_m: Distance ahead of the crest's apex (NaN for no crest).
        grade: Uphill grade before the crest (and downhill after), e.g. 0.06.
        crest_length_m: Length of the vertical curve between the two grades.
        behind_m: Road behind the vehicle, metres.
        ahead_m: Road ahead, metres.
        step_m: Sample spacing, metres.
    """
    d = np.arange(-behind_m, ahead_m + step_m / 2, step_m)
    k = curvature_1pm
    heading = k * d
    if abs(k) < 1e-9:
        x, y = d.copy(), np.zeros_like(d)
    else:
        x, y = np.sin(k * d) / k, (1.0 - np.cos(k * d)) / k
    z = np.zeros_like(d)
    if np.isfinite(crest_at_m) and grade != 0:
        # Grade +g up to the vertical curve, parabolic transition, then -g; z(0) = 0.
        a, b = crest_at_m - crest_length_m / 2, crest_at_m + crest_length_m / 2

        def zf(t: np.ndarray) -> np.ndarray:
            up = grade * t
            mid = grade * a + grade * (t - a) - grade * (t - a) ** 2 / crest_length_m
            top = grade * a + grade * crest_length_m / 2
            down = top - grade * (t - b)
            return np.where(t < a, up, np.where(t > b, down, mid))

        z = zf(d) - zf(np.zeros(1))
    return d + s0_m, x, y, z, heading


def standard_lines(
    lane_m: float = 3.6, lanes_right: int = 1, lanes_left: int = 1
) -> tuple[LaneLine, ...]:
    """Return the lines of a road with the ego lane centred on the reference line.

    Lines are ordered right to left, ``lanes_right`` of them right of the reference line; the
    ego lane (centred on the reference line) lies between indices ``lanes_right - 1``
    (its right line) and ``lanes_right`` (its left line).
    """
    n = lanes_right + lanes_left
    lines = []
    for i in range(n + 1):
        off = (i - lanes_right + 0.5) * lane_m
        outer = i in (0, n)
        if outer and i == n:
            lines.append(LaneLine(off, LineStyle.SOLID, LineColor.YELLOW, 0.12))
        elif outer:
            lines.append(LaneLine(off, LineStyle.SOLID, LineColor.WHITE, 0.15))
        else:
            lines.append(LaneLine(off, LineStyle.DASHED, LineColor.WHITE, 0.12, 3.0, 9.0, 1.0))
    return tuple(lines)


def example_scene(
    kind: str = "straight",
    conditions: Conditions | None = None,
    camera: CameraModel = DEFAULT_CAMERA,
    s0_m: float = 1000.0,
    with_objects: bool = True,
    seed: int = 0,
) -> FrameScene:
    """Return an example scene: ``straight``, ``curve`` (1/250 1/m left) or ``hill`` (crest).

    Args:
        kind: Which road.
        conditions: Frame conditions (defaults: clear day).
        camera: Camera model.
        s0_m: Arc length of the ego position (moves the textures and dashes).
        with_objects: Add a preceding car, a truck, trees, a guard rail, a sign.
        seed: World and frame seed.
    """
    k = {"straight": 0.0, "curve": 1.0 / 250.0, "hill": 0.0}[kind]
    crest = 90.0 if kind == "hill" else float("nan")
    s, x, y, z, hd = reference_line(s0_m, k, crest, 0.06)
    lines = standard_lines(3.6, lanes_right=1, lanes_left=2)
    road = RoadProfile(
        s_m=s,
        x_m=x,
        y_m=y,
        z_m=z,
        heading_rad=hd,
        lines=lines,
        left_edge_m=lines[-1].offset_m + 1.0,
        right_edge_m=lines[0].offset_m - 2.5,
        shoulder_m=2.5,
        surface="concrete" if kind == "straight" else "asphalt",
    )
    objects = _example_objects(road, s0_m, seed) if with_objects else ()
    return FrameScene(
        t_ns=0,
        camera=camera,
        road=road,
        objects=objects,
        conditions=conditions or Conditions(),
        ego_left_line=1,
        ego_right_line=0,
        corridor_length_m=26.0 if with_objects else 100.0,
        world_seed=seed,
        frame_seed=seed,
    )


def _example_objects(road: RoadProfile, s0_m: float, seed: int) -> tuple[SceneObject, ...]:
    """Return a preceding car, a car and a truck in the next lanes, a guard rail, trees, a sign.

    The trees' places and heights are drawn from ``seed``.
    """
    objs = []
    for d, lat, col, style, dims in (
        (28.0, 0.1, (40, 40, 40), "car", (4.6, 1.85, 1.45)),
        (55.0, 3.7, (190, 190, 195), "car", (4.5, 1.8, 1.5)),
        (80.0, 7.2, (200, 200, 200), "truck", (12.0, 2.5, 3.6)),
    ):
        px, py, pz, ph = _on_road(road, s0_m, d, lat)
        objs.append(SceneObject("vehicle", px, py, pz, *dims, ph, col, style))
    for d in range(8, 240, 4):
        px, py, pz, ph = _on_road(road, s0_m, float(d), road.right_edge_m - 0.6)
        objs.append(
            SceneObject(
                "building_wall_fence",
                px,
                py,
                pz,
                4.0,
                0.3,
                0.8,
                ph,
                (150, 155, 160),
                "guard_rail",
            )
        )
    rng = np.random.default_rng(seed)
    for d in range(20, 260, 9):
        px, py, pz, ph = _on_road(
            road, s0_m, float(d) + rng.uniform(0, 5), road.right_edge_m - 6 - rng.uniform(0, 8)
        )
        hgt = rng.uniform(6, 14)
        objs.append(
            SceneObject(
                "vegetation", px, py, pz, hgt * 0.6, hgt * 0.6, hgt, 0.0, (45, 90, 60), "tree"
            )
        )
    px, py, pz, ph = _on_road(road, s0_m, 70.0, road.right_edge_m - 1.5)
    objs.append(
        SceneObject("pole_sign_utility", px, py, pz, 0.2, 2.4, 3.8, ph, (70, 120, 20), "sign")
    )
    return tuple(objs)


def _on_road(
    road: RoadProfile, s0_m: float, d: float, lat: float
) -> tuple[float, float, float, float]:
    """Return ``(x, y, z, heading)`` of the road sample ``d`` m ahead, ``lat`` m left of it."""
    s, x, y, z, hd = road.s_m, road.x_m, road.y_m, road.z_m, road.heading_rad
    i = int(np.clip(np.searchsorted(s, s0_m + d), 0, s.size - 1))
    c, sn = np.cos(hd[i]), np.sin(hd[i])
    return x[i] - sn * lat, y[i] + c * lat, z[i], hd[i]
