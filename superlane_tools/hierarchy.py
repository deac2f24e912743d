"""The SUPER class hierarchy (paper Fig. 3): four levels, leaf ids, and per-level lookups.

Every label image in this package stores **leaf ids** (``uint8``), the finest node known for each
pixel. Coarser levels are derived with :func:`level_lut`. Id 0 is *void* (unlabelled / ignore).

Level 1: sky, vertical, support.
Level 2: vertical -> vehicle, person, building_wall_fence, vegetation, pole_sign_utility;
support -> sidewalk_curb, terrain_ground, drivable.
Level 3: drivable -> road, parking_service, crosswalk, lane_marking, other_marking.
Level 4: lane_marking -> dividing_white_solid, dividing_white_dashed, dividing_yellow_solid,
dividing_yellow_dashed, double_yellow, stop_line, guiding_turning.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray


class Node(NamedTuple):
    """One node of the hierarchy.

    Attributes:
        name: Snake-case node name, unique.
        parent: Parent node name, or ``""`` for level-1 nodes.
        level: Depth, 1 (coarsest) to 4.
        leaf_id: Id stored in label images when this node is the finest label, or -1 if the node
            is never stored (it always has a finer child in this package's labels).
        color_bgr: Display colour for overlays.
    """

    name: str
    parent: str
    level: int
    leaf_id: int
    color_bgr: tuple[int, int, int]


VOID = 0

NODES: tuple[Node, ...] = (
    Node("sky", "", 1, 1, (235, 206, 135)),
    Node("vertical", "", 1, -1, (128, 128, 128)),
    Node("support", "", 1, -1, (64, 64, 64)),
    Node("vehicle", "vertical", 2, 2, (142, 0, 0)),
    Node("person", "vertical", 2, 3, (60, 20, 220)),
    Node("building_wall_fence", "vertical", 2, 4, (70, 70, 70)),
    Node("vegetation", "vertical", 2, 5, (35, 142, 107)),
    Node("pole_sign_utility", "vertical", 2, 6, (0, 220, 220)),
    Node("sidewalk_curb", "support", 2, 7, (232, 35, 244)),
    Node("terrain_ground", "support", 2, 8, (152, 251, 152)),
    Node("drivable", "support", 2, -1, (128, 64, 128)),
    Node("road", "drivable", 3, 9, (128, 64, 128)),
    Node("parking_service", "drivable", 3, 10, (160, 170, 250)),
    Node("crosswalk", "drivable", 3, 11, (255, 255, 255)),
    Node("lane_marking", "drivable", 3, -1, (255, 255, 255)),
    Node("other_marking", "drivable", 3, 12, (200, 200, 200)),
    Node("dividing_white_solid", "lane_marking", 4, 13, (255, 255, 255)),
    Node("dividing_white_dashed", "lane_marking", 4, 14, (200, 255, 200)),
    Node("dividing_yellow_solid", "lane_marking", 4, 15, (0, 255, 255)),
    Node("dividing_yellow_dashed", "lane_marking", 4, 16, (0, 200, 255)),
    Node("double_yellow", "lane_marking", 4, 17, (0, 160, 255)),
    Node("stop_line", "lane_marking", 4, 18, (0, 0, 255)),
    Node("guiding_turning", "lane_marking", 4, 19, (255, 0, 255)),
)

BY_NAME: dict[str, Node] = {n.name: n for n in NODES}
N_LEAF_IDS = 1 + max(n.leaf_id for n in NODES)

#: Leaf id of every storable node, by name.
LEAF_IDS: dict[str, int] = {n.name: n.leaf_id for n in NODES if n.leaf_id >= 0}


def children(name: str) -> tuple[str, ...]:
    """Return the names of the direct children of node ``name`` (``""`` for level 1)."""
    return tuple(n.name for n in NODES if n.parent == name)


def ancestors(name: str) -> tuple[str, ...]:
    """Return ``name`` and its ancestors, finest first."""
    chain = [name]
    while BY_NAME[chain[-1]].parent:
        chain.append(BY_NAME[chain[-1]].parent)
    return tuple(chain)


def leaf_ids_under(name: str) -> tuple[int, ...]:
    """Return the leaf ids of ``name`` and of every node below it."""
    return tuple(n.leaf_id for n in NODES if n.leaf_id >= 0 and name in ancestors(n.name))


def node_at_level(leaf_name: str, level: int) -> str:
    """Return the ancestor of ``leaf_name`` at ``level`` (the node itself if it is coarser)."""
    chain = ancestors(leaf_name)
    for name in chain:
        if BY_NAME[name].level == level:
            return name
    return chain[0]


def level_lut(level: int) -> tuple[NDArray[np.uint8], tuple[str, ...]]:
    """Return a lookup table leaf id -> index at ``level`` and the names of those indices.

    Index 0 is void. Leaves coarser than ``level`` map to their own node (e.g. ``sky`` at level 3
    stays ``sky``), so the table is total.
    """
    names: list[str] = ["void"]
    lut = np.zeros(256, dtype=np.uint8)
    for node in NODES:
        if node.leaf_id < 0:
            continue
        target = node_at_level(node.name, level)
        if target not in names:
            names.append(target)
        lut[node.leaf_id] = names.index(target)
    return lut, tuple(names)


def colorize(leaf_ids: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Return a BGR ``(H, W, 3)`` overlay image for a leaf-id label image."""
    palette = np.zeros((256, 3), dtype=np.uint8)
    for node in NODES:
        if node.leaf_id >= 0:
            palette[node.leaf_id] = node.color_bgr
    out: NDArray[np.uint8] = palette[leaf_ids]
    return out
