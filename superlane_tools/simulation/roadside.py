"""Roadside scenery placed deterministically along the road: trees, buildings, rails, poles, signs.

Objects are generated once per world from a seeded generator as road coordinates (arc length
``s`` and lateral offset ``l``, metres) and converted to :class:`SceneObject` boxes in the vehicle
frame of each camera frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.road import EgoPose, Road, world_to_vehicle
from superlane_tools.simulation.scene import SceneObject

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RoadsideRecipe:
    """What stands beside the road.

    Attributes:
        trees_per_100m: Trees per 100 m per side.
        bushes_per_100m: Bushes per 100 m per side.
        buildings: Urban buildings on both sides.
        guard_rails: Guard rails along both paved edges.
        pole_spacing_m: Spacing of light/utility poles, metres (0 = none).
        signs_per_km: Traffic signs per km (right side).
        tree_distance_m: ``(min, max)`` distance of vegetation beyond the paved edge, metres.
    """

    trees_per_100m: float = 2.0
    bushes_per_100m: float = 3.0
    buildings: bool = False
    guard_rails: bool = True
    pole_spacing_m: float = 0.0
    signs_per_km: float = 4.0
    tree_distance_m: tuple[float, float] = (4.0, 25.0)


@dataclass(frozen=True)
class Roadside:
    """Static objects in road coordinates (parallel arrays).

    Attributes:
        kind: Hierarchy leaf name per object.
        style: Shape hint per object.
        s_m: Arc length of the object's centre, metres.
        l_m: Lateral offset of the object's centre, metres.
        z_m: Height of the object's bottom above the road surface, metres.
        size_m: ``(N, 3)`` length, width, height, metres.
        color_bgr: ``(N, 3)`` base colours.
    """

    kind: tuple[str, ...]
    style: tuple[str, ...]
    s_m: FloatArray
    l_m: FloatArray
    z_m: FloatArray
    size_m: FloatArray
    color_bgr: NDArray[np.int64]


_GREENS = ((40, 90, 50), (30, 110, 60), (50, 120, 90), (35, 75, 45), (60, 130, 110))
_FACADES = ((150, 160, 170), (110, 120, 140), (90, 100, 120), (170, 180, 190), (80, 90, 130))


_Row = tuple[str, str, float, float, float, float, float, float, tuple[int, int, int]]
"""One object: kind, style, ``s``, ``l``, ``z`` (m), length, width, height (m), colour."""


def build_roadside(road: Road, recipe: RoadsideRecipe, rng: np.random.Generator) -> Roadside:
    """Place roadside objects along the whole road."""
    rows: list[_Row] = []
    length = road.length_m
    curb = road.recipe.sidewalk_m
    left_edge, right_edge = road.left_edge_m + curb, road.right_edge_m - curb
    for side in (1.0, -1.0):
        edge = left_edge if side > 0 else right_edge
        rows += _vegetation(recipe, length, edge, side, rng)
        if recipe.guard_rails:
            rows += _guard_rails(length, edge, side)
        if recipe.buildings:
            rows += _buildings(length, edge, side, rng)
        if recipe.pole_spacing_m > 0:
            rows += _poles(recipe.pole_spacing_m, length, edge, side, rng)
    rows += _signs(recipe.signs_per_km, length, right_edge, rng)
    rows.sort(key=lambda r: (r[2], r[3]))
    return Roadside(
        kind=tuple(r[0] for r in rows),
        style=tuple(r[1] for r in rows),
        s_m=np.array([r[2] for r in rows], dtype=np.float64),
        l_m=np.array([r[3] for r in rows], dtype=np.float64),
        z_m=np.array([r[4] for r in rows], dtype=np.float64),
        size_m=np.array([[r[5], r[6], r[7]] for r in rows], dtype=np.float64).reshape(-1, 3),
        color_bgr=np.array([r[8] for r in rows], dtype=np.int64).reshape(-1, 3),
    )


def _pick(
    rng: np.random.Generator, options: tuple[tuple[int, int, int], ...]
) -> tuple[int, int, int]:
    """Draw one of ``options``."""
    return options[int(rng.integers(len(options)))]


def _vegetation(
    recipe: RoadsideRecipe, length: float, edge: float, side: float, rng: np.random.Generator
) -> list[_Row]:
    """Return trees, then bushes, beyond the paved ``edge`` on one ``side`` (+1 left, -1 right)."""
    rows: list[_Row] = []
    for _ in range(int(rng.poisson(recipe.trees_per_100m * length / 100.0))):
        s = float(rng.uniform(0.0, length))
        dist = float(rng.uniform(*recipe.tree_distance_m))
        h = float(rng.uniform(4.0, 12.0))
        w = float(rng.uniform(2.0, 5.0))
        rows.append(
            (
                "vegetation",
                "tree",
                s,
                edge + side * (dist + w / 2),
                0.0,
                w,
                w,
                h,
                _pick(rng, _GREENS),
            )
        )
    for _ in range(int(rng.poisson(recipe.bushes_per_100m * length / 100.0))):
        s = float(rng.uniform(0.0, length))
        near = min(1.5, recipe.tree_distance_m[0])
        dist = float(rng.uniform(near, max(near + 0.5, recipe.tree_distance_m[1] * 0.5)))
        w = float(rng.uniform(1.0, 3.0))
        rows.append(
            (
                "vegetation",
                "bush",
                s,
                edge + side * (dist + w / 2),
                0.0,
                w * 1.5,
                w,
                float(rng.uniform(0.6, 1.8)),
                _pick(rng, _GREENS),
            )
        )
    return rows


def _guard_rails(length: float, edge: float, side: float) -> list[_Row]:
    """Return 8 m guard-rail pieces along the whole paved ``edge``."""
    return [
        (
            "building_wall_fence",
            "guard_rail",
            float(s) + 4.0,
            edge + side * 0.6,
            0.0,
            8.0,
            0.3,
            0.75,
            (150, 150, 150),
        )
        for s in np.arange(0.0, length, 8.0)
    ]


def _buildings(length: float, edge: float, side: float, rng: np.random.Generator) -> list[_Row]:
    """Return a row of buildings of random length, depth, setback and height along ``edge``."""
    rows: list[_Row] = []
    s = float(rng.uniform(0.0, 10.0))
    while s < length:
        blen = float(rng.uniform(10.0, 30.0))
        depth = float(rng.uniform(8.0, 15.0))
        setback = float(rng.uniform(1.0, 6.0))
        rows.append(
            (
                "building_wall_fence",
                "building",
                s + blen / 2,
                edge + side * (setback + depth / 2),
                0.0,
                blen,
                depth,
                float(rng.uniform(6.0, 25.0)),
                _pick(rng, _FACADES),
            )
        )
        s += blen + float(rng.uniform(2.0, 15.0))
    return rows


def _poles(
    spacing_m: float, length: float, edge: float, side: float, rng: np.random.Generator
) -> list[_Row]:
    """Return light/utility poles every ``spacing_m`` metres from a random start along ``edge``."""
    first = float(rng.uniform(0.0, spacing_m))
    return [
        (
            "pole_sign_utility",
            "pole",
            float(s),
            edge + side * 0.8,
            0.0,
            0.25,
            0.25,
            8.0,
            (120, 120, 120),
        )
        for s in np.arange(first, length, spacing_m)
    ]


def _signs(
    signs_per_km: float, length: float, right_edge: float, rng: np.random.Generator
) -> list[_Row]:
    """Return traffic signs (a sign on a pole, 1.5 m right of ``right_edge``) at random places."""
    rows: list[_Row] = []
    for _ in range(int(rng.poisson(signs_per_km * length / 1000.0))):
        s = float(rng.uniform(0.0, length))
        l_sign = right_edge - 1.5
        rows.append(("pole_sign_utility", "pole", s, l_sign, 0.0, 0.1, 0.1, 2.2, (140, 140, 140)))
        rows.append(
            (
                "pole_sign_utility",
                "sign",
                s,
                l_sign,
                2.0,
                0.1,
                1.2,
                1.0,
                _pick(rng, ((40, 120, 30), (30, 30, 200), (200, 200, 200), (180, 100, 20))),
            )
        )
    return rows


def road_objects(
    road: Road,
    pose: EgoPose,
    s_m: FloatArray,
    l_m: FloatArray,
    heading_offset_rad: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Convert road coordinates to vehicle-frame ``(x, y, z, yaw)`` of object bottom centres.

    Args:
        road: The road.
        pose: Ego pose of the frame.
        s_m: Arc lengths, metres.
        l_m: Lateral offsets, metres.
        heading_offset_rad: Object heading relative to the road direction, radians.
    """
    smp = road.sample(s_m)
    wx = smp["x"] - l_m * np.sin(smp["heading"])
    wy = smp["y"] + l_m * np.cos(smp["heading"])
    x, y, z = world_to_vehicle(pose, wx, wy, smp["z"])
    yaw = (smp["heading"] + heading_offset_rad - pose.heading_rad + np.pi) % (2 * np.pi) - np.pi
    return x, y, z, yaw


def visible_roadside(
    road: Road, side: Roadside, pose: EgoPose, ahead_m: float = 200.0, behind_m: float = 5.0
) -> tuple[SceneObject, ...]:
    """Return the roadside objects between ``behind_m`` and ``ahead_m`` of the ego pose."""
    lo = np.searchsorted(side.s_m, pose.s_m - behind_m - 20.0)
    hi = np.searchsorted(side.s_m, pose.s_m + ahead_m)
    idx = np.arange(lo, hi)
    if not len(idx):
        return ()
    x, y, z, yaw = road_objects(road, pose, side.s_m[idx], side.l_m[idx], np.zeros(len(idx)))
    out: list[SceneObject] = []
    for j, i in enumerate(idx):
        length = float(side.size_m[i, 0])
        if x[j] + length / 2 < -behind_m or x[j] > ahead_m:
            continue
        c = side.color_bgr[i]
        out.append(
            SceneObject(
                kind=side.kind[i],
                x_m=float(x[j]),
                y_m=float(y[j]),
                z_m=float(z[j] + side.z_m[i]),
                length_m=length,
                width_m=float(side.size_m[i, 1]),
                height_m=float(side.size_m[i, 2]),
                yaw_rad=float(yaw[j]),
                color_bgr=(int(c[0]), int(c[1]), int(c[2])),
                style=side.style[i],
            )
        )
    return tuple(out)
