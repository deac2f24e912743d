"""Dataset adapters: YAML maps from a dataset's label ids to hierarchy nodes, and their loader.

A label image in a dataset's own ids becomes a node-code image (see
:mod:`superlane_tools.scene.adapters.heads`); unmapped ids become void. The ``apollo_lane``
preprocessing implements SUPER II-C: lane markings are kept, their vicinity is labelled ``road``
and pixels of occluding objects are dropped from that vicinity.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.config_files import load_document, parse_document
from superlane_tools.errors import ConfigError
from superlane_tools.hierarchy import BY_NAME, LEAF_IDS, ancestors
from superlane_tools.scene.adapters.heads import NODE_CODES

_PACKAGE = "superlane_tools.scene.adapters"
SUPERLANE = "superlane"
"""Name of the built-in identity adapter: label images that already store leaf ids."""
_PREPROCESS = ("none", "apollo_lane")


@dataclass(frozen=True)
class DatasetAdapter:
    """Map one dataset's label ids onto the hierarchy.

    Attributes:
        name: Adapter name (``cityscapes``, ``mapillary_vistas``, ``apollo``, ``superlane``).
        id_to_node: Dataset label id -> hierarchy node name; other ids are void.
        preprocess: ``none`` or ``apollo_lane`` (marking vicinity -> road, drop occluded road).
        expand_px: Vicinity radius for ``apollo_lane``, pixels at the label resolution.
        occluder_ids: Dataset ids that occlude the road for ``apollo_lane``.
        description: Human-readable description.
    """

    name: str
    id_to_node: dict[int, str] = field(default_factory=dict)
    preprocess: str = "none"
    expand_px: int = 0
    occluder_ids: tuple[int, ...] = ()
    description: str = ""

    def lut(self) -> NDArray[np.uint8]:
        """Return the 256-entry table dataset id -> node code."""
        table = np.zeros(256, dtype=np.uint8)
        for label_id, node in self.id_to_node.items():
            table[label_id] = NODE_CODES[node]
        return table

    def to_codes(self, labels: NDArray[np.integer[Any]]) -> NDArray[np.uint8]:
        """Convert an ``(H, W)`` label image in the dataset's ids into node codes."""
        ids = np.asarray(labels)
        if ids.ndim != 2:
            raise ConfigError(f"{self.name}: label image must be 2-D, got shape {ids.shape}")
        if ids.size and (int(ids.min()) < 0 or int(ids.max()) > 255):
            raise ConfigError(f"{self.name}: label ids must lie in 0..255")
        codes = self.lut()[ids.astype(np.uint8)]
        if self.preprocess == "apollo_lane":
            codes = self._apollo_vicinity(ids, codes)
        return codes

    def _apollo_vicinity(
        self, ids: NDArray[np.integer[Any]], codes: NDArray[np.uint8]
    ) -> NDArray[np.uint8]:
        import cv2  # late: heavy import

        drivable = {NODE_CODES[n] for n in NODE_CODES if n != "void" and _is_drivable(n)}
        marking = np.isin(codes, sorted(drivable))
        size = 2 * self.expand_px + 1
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
        vicinity = cv2.dilate(marking.astype(np.uint8), kernel).astype(bool)
        occluded = np.isin(ids, list(self.occluder_ids))
        out = codes.copy()
        out[vicinity & ~marking & ~occluded] = NODE_CODES["road"]
        return out

    def inverse(self, leaf_ids: NDArray[np.uint8], fill: int = 0) -> NDArray[np.uint8]:
        """Export a leaf-id image in this dataset's ids (for tests and dataset conversion).

        Each leaf takes the dataset id whose node is the leaf itself or its nearest ancestor
        (first such id in the map); leaves the dataset cannot express get ``fill``.
        """
        table = np.full(256, fill, dtype=np.uint8)
        for leaf_name, leaf_id in LEAF_IDS.items():
            for name in ancestors(leaf_name):
                hits = [i for i, n in self.id_to_node.items() if n == name]
                if hits:
                    table[leaf_id] = hits[0]
                    break
        out: NDArray[np.uint8] = table[leaf_ids]
        return out


def _is_drivable(name: str) -> bool:
    node = BY_NAME[name]
    return "drivable" in ancestors(name)[1:] and node.name not in {"road", "parking_service"}


def identity_adapter() -> DatasetAdapter:
    """Return the adapter of label images that already store leaf ids."""
    mapping = {leaf_id: name for name, leaf_id in LEAF_IDS.items()}
    return DatasetAdapter(SUPERLANE, mapping, description="superlane leaf ids (identity)")


def list_adapters() -> list[str]:
    """Return the names of the bundled adapters, sorted (the identity adapter included)."""
    folder = resources.files(_PACKAGE)
    names = [e.name.removesuffix(".yaml") for e in folder.iterdir() if e.name.endswith(".yaml")]
    return sorted([*names, SUPERLANE])


def adapter_from_mapping(data: Any, source: str) -> DatasetAdapter:
    """Build an adapter from a parsed YAML mapping.

    Raises:
        ConfigError: If the mapping is malformed or names unknown nodes.
    """
    if not isinstance(data, dict) or not isinstance(data.get("map"), dict):
        raise ConfigError(f"{source}: an adapter needs a `map:` of label id -> node name")
    mapping: dict[int, str] = {}
    for key, node in data["map"].items():
        try:
            label_id = int(key)
        except (TypeError, ValueError) as err:
            raise ConfigError(f"{source}: label id {key!r} is not an integer") from err
        if not 0 <= label_id <= 255:
            raise ConfigError(f"{source}: label id {label_id} outside 0..255")
        if node not in BY_NAME:
            raise ConfigError(f"{source}: id {label_id} maps to unknown node {node!r}")
        mapping[label_id] = str(node)
    preprocess = str(data.get("preprocess", "none"))
    if preprocess not in _PREPROCESS:
        raise ConfigError(f"{source}: preprocess must be one of {_PREPROCESS}, got {preprocess!r}")
    apollo = data.get("apollo") or {}
    try:
        expand_px = int(apollo.get("expand_px", 0))
        occluders = tuple(int(i) for i in apollo.get("occluder_ids", ()))
    except (TypeError, ValueError, AttributeError) as err:
        raise ConfigError(f"{source}: bad `apollo:` section: {err}") from err
    return DatasetAdapter(
        name=str(data.get("name", Path(source).stem)),
        id_to_node=mapping,
        preprocess=preprocess,
        expand_px=expand_px,
        occluder_ids=occluders,
        description=str(data.get("description", "")),
    )


def load_adapter(name_or_path: str | os.PathLike[str]) -> DatasetAdapter:
    """Load a bundled adapter by name or a YAML adapter file by path.

    Raises:
        ConfigError: If the name is unknown or the file is invalid.
    """
    text = str(name_or_path)
    if text == SUPERLANE:
        return identity_adapter()
    path = Path(text)
    if path.suffix in {".yaml", ".yml"} or path.exists():
        return adapter_from_mapping(load_document(path, "adapter", ".yaml"), str(path))
    entry = resources.files(_PACKAGE).joinpath(f"{text}.yaml")
    if not entry.is_file():
        known = ", ".join(list_adapters())
        raise ConfigError(f"unknown dataset adapter {text!r} (bundled: {known})")
    return adapter_from_mapping(parse_document(entry.read_text(encoding="utf-8"), text), text)
