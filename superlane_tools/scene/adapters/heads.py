"""Hierarchy heads: node codes, per-head training targets and parent-governed decoding.

A *node code* image (``uint8``) stores, per pixel, the finest hierarchy node a dataset labels
there: ``code = 1 + index in hierarchy.NODES``, 0 = void. Unlike leaf ids it can say "drivable,
finer class unknown" (Cityscapes' road) or "lane marking, type unknown" (Vistas).

One softmax head per parent node (SUPER Fig. 3): :data:`HEADS`. A pixel trains a head only when
its node lies strictly below the head's parent (elsewhere the head's target is ``IGNORE``), so
datasets that stop at a coarser level simply do not train the finer heads. At inference each
child is governed by its parent's decision: argmax down the tree (:func:`decode_heads`).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import BY_NAME, NODES, ancestors, children

IGNORE = -1
"""Target value of pixels a head does not learn from (``ignore_index`` of the loss)."""

NODE_NAMES: tuple[str, ...] = ("void", *(n.name for n in NODES))
NODE_CODES: dict[str, int] = {name: i for i, name in enumerate(NODE_NAMES)}

DEFAULT_LEAF: dict[str, str] = {
    "vertical": "building_wall_fence",
    "support": "terrain_ground",
    "drivable": "road",
    "lane_marking": "dividing_white_solid",
}
"""Leaf stored for an inner node when a model has no head to refine it (user-plugged models)."""


class Head(NamedTuple):
    """One softmax classifier of the hierarchy.

    Attributes:
        name: Output name in ONNX graphs, e.g. ``head_drivable``.
        parent: Parent node name (``""`` for the level-1 head).
        classes: Node names of the head's channels, in channel order.
    """

    name: str
    parent: str
    classes: tuple[str, ...]


def _head(parent: str) -> Head:
    return Head(f"head_{parent or 'root'}", parent, children(parent))


HEADS: tuple[Head, ...] = tuple(
    _head(p) for p in ("", "vertical", "support", "drivable", "lane_marking")
)
"""The five heads of the SUPER hierarchy, parents before children."""


def leaf_to_codes(leaf_ids: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Convert a leaf-id label image into a node-code image."""
    lut = np.zeros(256, dtype=np.uint8)
    for node in NODES:
        if node.leaf_id >= 0:
            lut[node.leaf_id] = NODE_CODES[node.name]
    out: NDArray[np.uint8] = lut[leaf_ids]
    return out


def codes_to_leaf(codes: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Convert node codes to leaf ids; inner nodes take their :data:`DEFAULT_LEAF`."""
    out: NDArray[np.uint8] = np.take(_leaf_lut(), codes)
    return out


@cache
def _leaf_lut() -> NDArray[np.uint8]:
    """Return the 256-entry table node code -> leaf id of :func:`codes_to_leaf`."""
    lut = np.zeros(256, dtype=np.uint8)
    for name, code in NODE_CODES.items():
        if name == "void":
            continue
        node = BY_NAME[name]
        while node.leaf_id < 0:
            node = BY_NAME[DEFAULT_LEAF[node.name]]
        lut[code] = node.leaf_id
    lut.flags.writeable = False
    return lut


@cache
def _class_codes(classes: tuple[str, ...]) -> NDArray[np.uint8]:
    """Return the 256-entry table channel index -> node code of a head's classes."""
    lut = np.zeros(256, dtype=np.uint8)
    lut[: len(classes)] = [NODE_CODES[c] for c in classes]
    lut.flags.writeable = False
    return lut


def head_target_lut(head: Head) -> NDArray[np.int64]:
    """Return a 256-entry table node code -> class index of ``head`` (``IGNORE`` if not below)."""
    lut = np.full(256, IGNORE, dtype=np.int64)
    for name, code in NODE_CODES.items():
        if name == "void":
            continue
        for cls_index, cls in enumerate(head.classes):
            if cls in ancestors(name):
                lut[code] = cls_index
    return lut


def head_targets(
    codes: NDArray[np.uint8], heads: Sequence[Head] = HEADS
) -> list[NDArray[np.int64]]:
    """Return one ``int64`` target image per head (class index or ``IGNORE``)."""
    return [head_target_lut(h)[codes] for h in heads]


def decode_heads(
    scores: Sequence[NDArray[np.floating]], heads: Sequence[Head] = HEADS
) -> NDArray[np.uint8]:
    """Decode per-head scores into leaf ids by argmax down the tree.

    Args:
        scores: One ``(C_k, H, W)`` logit or probability array per head, in ``heads`` order.
        heads: The heads, parents before children; the first has parent ``""``. Its classes may
            be any nodes (a flat user model); later heads refine pixels whose current node is
            their parent.

    Returns:
        ``(H, W)`` ``uint8`` leaf ids.
    """
    current = np.take(_class_codes(tuple(heads[0].classes)), argmax_channels(scores[0]))
    for head, score in zip(heads[1:], scores[1:], strict=True):
        mask = current == NODE_CODES[head.parent]
        if not mask.any():
            continue
        refined = np.take(_class_codes(tuple(head.classes)), argmax_channels(score))
        current = np.where(mask, refined, current)
    return codes_to_leaf(current)


def argmax_channels(scores: NDArray[np.floating]) -> NDArray[np.uint8]:
    """Return the ``(H, W)`` index of the largest of ``(C, H, W)`` scores (first on ties).

    Equals ``np.argmax(scores, axis=0)`` for scores without NaN (C <= 255), but runs one
    vectorised comparison per channel over contiguous planes instead of a strided argmax per
    pixel (about 10x faster for the few channels of a head). A channel that beats every
    earlier one is larger than any index held so far, so ``max(index, channel * larger)``
    takes it without a masked write.
    """
    best = np.array(scores[0], copy=True)
    index = np.zeros(best.shape, dtype=np.uint8)
    larger = np.empty(best.shape, dtype=bool)
    step = np.empty(best.shape, dtype=np.uint8)
    for channel in range(1, scores.shape[0]):
        np.greater(scores[channel], best, out=larger)
        np.multiply(larger.view(np.uint8), channel, out=step)
        np.maximum(index, step, out=index)
        np.maximum(best, scores[channel], out=best)
    return index


def validate_heads(heads: Sequence[Head]) -> list[str]:
    """Return the problems of a head list (empty when valid): unknown nodes, bad parents."""
    problems: list[str] = []
    if not heads or heads[0].parent:
        problems.append("the first head must have parent '' (the root)")
    seen_parents: set[str] = set()
    for head in heads:
        if head.parent and head.parent not in BY_NAME:
            problems.append(f"{head.name}: unknown parent node {head.parent!r}")
        if head.parent in seen_parents:
            problems.append(f"{head.name}: a second head for parent {head.parent!r}")
        seen_parents.add(head.parent)
        for cls in head.classes:
            if cls not in BY_NAME:
                problems.append(f"{head.name}: unknown class node {cls!r}")
            elif head.parent and head.parent not in ancestors(cls)[1:]:
                problems.append(f"{head.name}: {cls!r} is not below {head.parent!r}")
    return problems
