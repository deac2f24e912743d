"""Label image -> fit input: lane-marking pixels with attribute codes, and road pixels.

The one pixel extraction of the lane stage. A class map says which label ids are lane markings
(with their level-4 attribute code) and which are road; :func:`label_points` returns the pixels
the SUPER fit takes, each kind capped by a deterministic subsample that depends on the seed only.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.lanes.attributes import CODE_OF

FloatArray = NDArray[np.float64]
MAX_LANE_PIXELS = 50_000
"""Lane pixels per frame passed to the fit at most (deterministic subsample above it)."""
MAX_ROAD_PIXELS = 20_000
"""Road pixels per frame passed to the fit at most."""


class ClassLookup(NamedTuple):
    """Label id -> lane attribute code + 1 (0: not a lane marking), and label id -> road."""

    code: NDArray[np.int16]
    road: NDArray[np.bool_]

    @classmethod
    def from_ids(
        cls, code_of_id: Mapping[int, int], road_ids: tuple[int, ...], size: int = 256
    ) -> ClassLookup:
        """Build the tables from lane-marking id -> attribute code and the road ids."""
        size = max(size, *(i + 1 for i in code_of_id), *(i + 1 for i in road_ids))
        code = np.zeros(size, dtype=np.int16)
        road = np.zeros(size, dtype=bool)
        for class_id, marking in code_of_id.items():
            code[class_id] = marking + 1
        road[list(road_ids)] = True
        return cls(code, road)


def leaf_lookup() -> ClassLookup:
    """Return the lookup of the class hierarchy's leaf ids (labels of ``slt segment``)."""
    code_of_id = {LEAF_IDS[n]: c for n, c in CODE_OF.items() if n in LEAF_IDS}
    return ClassLookup.from_ids(code_of_id, (*sorted(code_of_id), LEAF_IDS["road"]))


LEAF_LOOKUP = leaf_lookup()


class LabelPoints(NamedTuple):
    """Pixels of one label image that the fit uses.

    Attributes:
        lane_uv: ``(N, 2)`` lane-marking pixels ``(u, v)``.
        codes: ``(N,)`` level-4 attribute codes of the lane pixels.
        road_uv: ``(M, 2)`` road pixels (road plus lane markings), or None when not asked for.
    """

    lane_uv: FloatArray
    codes: NDArray[np.intp]
    road_uv: FloatArray | None


def _capped(
    rows: NDArray[np.intp], cols: NDArray[np.intp], cap: int, seed: int
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    if rows.size > cap:
        keep = np.sort(np.random.default_rng(seed).choice(rows.size, cap, False))
        rows, cols = rows[keep], cols[keep]
    return rows, cols


def lane_points(
    labels: NDArray[np.integer], lookup: ClassLookup = LEAF_LOOKUP, seed: int = 0
) -> tuple[FloatArray, NDArray[np.intp]]:
    """Return lane-marking pixels ``(N, 2)`` ``(u, v)`` and their attribute codes."""
    code = lookup.code[labels]
    rows, cols = np.nonzero(code)
    rows, cols = _capped(rows, cols, MAX_LANE_PIXELS, seed)
    uv = np.stack([cols, rows], axis=1).astype(np.float64)
    return uv, (code[rows, cols] - 1).astype(np.intp)


def road_points(
    labels: NDArray[np.integer], lookup: ClassLookup = LEAF_LOOKUP, seed: int = 0
) -> FloatArray:
    """Return road pixels (road plus lane markings) ``(M, 2)`` ``(u, v)``, capped."""
    rows, cols = np.nonzero(lookup.road[labels])
    rows, cols = _capped(rows, cols, MAX_ROAD_PIXELS, seed)
    return np.stack([cols, rows], axis=1).astype(np.float64)


def label_points(
    labels: NDArray[np.integer],
    lookup: ClassLookup = LEAF_LOOKUP,
    seed: int = 0,
    road: bool = True,
) -> LabelPoints:
    """Return the lane pixels with codes and (when ``road``) the road pixels of a label image.

    Args:
        labels: ``(H, W)`` integer label ids (ids beyond the lookup's tables are neither).
        lookup: Which ids are lane markings (and their codes) and road.
        seed: Seed of the subsampling above :data:`MAX_LANE_PIXELS` / :data:`MAX_ROAD_PIXELS`.
        road: Also return the road pixels.
    """
    size = int(labels.max(initial=0)) + 1
    if size > lookup.code.size:
        pad = size - lookup.code.size
        lookup = ClassLookup(np.pad(lookup.code, (0, pad)), np.pad(lookup.road, (0, pad)))
    lane_uv, codes = lane_points(labels, lookup, seed)
    return LabelPoints(lane_uv, codes, road_points(labels, lookup, seed) if road else None)
