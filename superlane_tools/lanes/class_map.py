"""Which class ids of a label image are lane markings and road (``classes.yaml``); their pixels."""

from __future__ import annotations

import os
from typing import Any, NamedTuple

from numpy.typing import NDArray

from superlane_tools.errors import ConfigError
from superlane_tools.lanes.attributes import CODE_OF
from superlane_tools.lanes.points import ClassLookup, LabelPoints, label_points


class ClassMap(NamedTuple):
    """Which class ids of the masks are lane markings and road.

    Attributes:
        lane_ids: Ids of lane-marking pixels (``lane_marking`` and its finer marking nodes).
        road_ids: Ids of road pixels for J1 (``road`` plus the lane markings on it).
        code_of_id: Lane-marking id -> level-4 attribute code (0 when unspecific).
    """

    lane_ids: tuple[int, ...]
    road_ids: tuple[int, ...]
    code_of_id: dict[int, int]


def parse_classes(data: Any, source: str = "<classes>") -> ClassMap:
    """Build a :class:`ClassMap` from a parsed ``classes.yaml`` mapping (node -> id or ids).

    Raises:
        ConfigError: If the mapping is malformed or names no lane-marking node.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping of class nodes to integer ids")
    ids: dict[str, list[int]] = {}
    for node, value in data.items():
        values = value if isinstance(value, list) else [value]
        if not values or not all(isinstance(v, int) and not isinstance(v, bool) for v in values):
            raise ConfigError(f"{source}: {node!r} must map to an integer id or a list of ids")
        ids[str(node)] = [int(v) for v in values]
    code_of_id: dict[int, int] = {}
    for node, code in CODE_OF.items():
        for class_id in ids.get(node, []):
            code_of_id[class_id] = code
    if not code_of_id:
        raise ConfigError(
            f"{source}: no lane-marking node (lane_marking, dividing_white_solid, ...) is mapped"
        )
    lane_ids = tuple(sorted(code_of_id))
    road_ids = tuple(sorted(set(ids.get("road", [])) | set(lane_ids)))
    return ClassMap(lane_ids, road_ids, code_of_id)


def load_classes(path: str | os.PathLike[str]) -> ClassMap:
    """Read ``classes.yaml``.

    Raises:
        ConfigError: If the file is missing, not YAML, or malformed.
    """
    from superlane_tools.config_files import load_document

    return parse_classes(load_document(path, "class map", suffix=".yaml"), str(path))


def mask_points(mask: NDArray[Any], classes: ClassMap, seed: int = 0) -> LabelPoints:
    """Return the lane and road pixels of a class-id mask (see :func:`lanes.points.label_points`).

    Args:
        mask: ``(H, W)`` integer class ids.
        classes: Which ids are lane markings and road.
        seed: Seed of the deterministic subsampling of each kind.
    """
    lookup = ClassLookup.from_ids(classes.code_of_id, classes.road_ids)
    return label_points(mask, lookup, seed)
