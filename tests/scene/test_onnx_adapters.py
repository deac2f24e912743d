"""Dataset adapters: Cityscapes-, Vistas- and Apollo-style label images map onto the hierarchy."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from superlane_tools.errors import ConfigError
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.scene.adapters import (
    HEADS,
    IGNORE,
    NODE_CODES,
    codes_to_leaf,
    decode_heads,
    head_targets,
    leaf_to_codes,
    list_adapters,
    load_adapter,
    validate_heads,
)
from superlane_tools.scene.adapters.heads import argmax_channels
from superlane_tools.training.toy_dataset import toy_frame


def _sim_labels() -> np.ndarray:
    """Leaf ids of a frame rendered by the drive simulator (a curve with traffic)."""
    from superlane_tools.simulation.render import render
    from superlane_tools.simulation.render.examples import DEFAULT_CAMERA, example_scene

    labels = render(example_scene("curve", camera=DEFAULT_CAMERA.resized(320, 180))).labels
    assert (labels == LEAF_IDS["dividing_white_dashed"]).any()
    return np.asarray(labels, dtype=np.uint8)


@pytest.fixture(params=["toy", "simulator"])
def leaf(request: pytest.FixtureRequest) -> np.ndarray:
    """A leaf-id label image: a toy frame, or a simulator frame exported in each style."""
    if request.param == "simulator":
        labels = _sim_labels()
    else:
        _, labels, _ = toy_frame(np.random.default_rng(3), 160, 96)
    labels = labels.copy()
    labels[:4, :10] = LEAF_IDS["person"]
    labels[-6:, :20] = LEAF_IDS["sidewalk_curb"]
    labels[-6:, -20:] = LEAF_IDS["stop_line"]
    return np.asarray(labels, dtype=np.uint8)


def _roundtrip(tmp_path: Path, name: str, leaf: np.ndarray) -> np.ndarray:
    adapter = load_adapter(name)
    exported = adapter.inverse(leaf)
    path = tmp_path / f"{name}.png"
    assert cv2.imwrite(str(path), exported)
    return adapter.to_codes(cv2.imread(str(path), cv2.IMREAD_UNCHANGED))


def test_bundled_adapters_are_listed() -> None:
    assert {"apollo", "cityscapes", "mapillary_vistas", "superlane"} <= set(list_adapters())


def test_identity_adapter_roundtrips_leaf_ids(tmp_path: Path, leaf: np.ndarray) -> None:
    codes = _roundtrip(tmp_path, "superlane", leaf)
    assert np.array_equal(codes_to_leaf(codes), leaf)


def test_cityscapes_road_is_drivable_without_finer_targets(
    tmp_path: Path, leaf: np.ndarray
) -> None:
    codes = _roundtrip(tmp_path, "cityscapes", leaf)
    on_road = np.isin(leaf, [LEAF_IDS["road"], LEAF_IDS["dividing_white_dashed"]])
    assert (codes[on_road] == NODE_CODES["drivable"]).all()
    assert (codes[leaf == LEAF_IDS["sky"]] == NODE_CODES["sky"]).all()
    assert (codes[leaf == LEAF_IDS["vehicle"]] == NODE_CODES["vehicle"]).all()
    root, _, support, drivable, marking = head_targets(codes)
    assert (root[on_road] == HEADS[0].classes.index("support")).all()
    assert (support[on_road] == HEADS[2].classes.index("drivable")).all()
    assert (drivable == IGNORE).all()  # Cityscapes does not label the drivable level
    assert (marking == IGNORE).all()


def test_vistas_keeps_markings_as_untyped_lane_marking(tmp_path: Path, leaf: np.ndarray) -> None:
    codes = _roundtrip(tmp_path, "mapillary_vistas", leaf)
    lines = np.isin(leaf, [LEAF_IDS["dividing_white_dashed"], LEAF_IDS["dividing_yellow_solid"]])
    assert (codes[lines] == NODE_CODES["lane_marking"]).all()
    assert (codes[leaf == LEAF_IDS["road"]] == NODE_CODES["road"]).all()
    _, _, _, drivable, marking = head_targets(codes)
    assert (drivable[lines] == HEADS[3].classes.index("lane_marking")).all()
    assert (marking == IGNORE).all()


def test_apollo_preprocessing_expands_markings_into_road(tmp_path: Path, leaf: np.ndarray) -> None:
    adapter = load_adapter("apollo")
    exported = adapter.inverse(leaf)  # markings only; everything else void (0)
    exported[leaf == LEAF_IDS["vehicle"]] = 255  # Apollo's `ignored`: occluders
    path = tmp_path / "apollo.png"
    assert cv2.imwrite(str(path), exported)
    codes = adapter.to_codes(cv2.imread(str(path), cv2.IMREAD_UNCHANGED))
    white = leaf == LEAF_IDS["dividing_white_dashed"]
    assert (codes[white] == NODE_CODES["dividing_white_dashed"]).all()
    assert (codes[leaf == LEAF_IDS["stop_line"]] == NODE_CODES["stop_line"]).all()
    road = codes == NODE_CODES["road"]
    assert road.any()
    assert not road[leaf == LEAF_IDS["vehicle"]].any()  # occluded road dropped
    assert not road[:20].any()  # sky rows far above the markings stay void
    off_marking = (~np.isin(exported, list(adapter.id_to_node))).astype(np.uint8)
    dist = cv2.distanceTransform(off_marking, cv2.DIST_L2, 5)
    assert dist[road].max() <= adapter.expand_px + 1.5


def test_bad_adapter_files_are_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("map:\n  7: not_a_node\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="unknown node"):
        load_adapter(bad)
    with pytest.raises(ConfigError, match="unknown dataset adapter"):
        load_adapter("kitti360")


def test_decode_heads_follows_parent_decisions() -> None:
    h, w = 2, 3
    scores = [np.zeros((len(head.classes), h, w), np.float32) for head in HEADS]
    scores[0][2] = 1.0  # support everywhere
    scores[0][0, 0, 0] = 5.0  # ... but sky at (0, 0)
    scores[2][2] = 1.0  # drivable
    scores[3][3] = 1.0  # lane marking
    scores[3][0, 1, :] = 5.0  # road on row 1
    scores[4][5] = 1.0  # stop line
    scores[1][0] = 9.0  # vehicle head is loud but never consulted (no vertical pixel)
    leaf = decode_heads(scores)
    assert leaf[0, 0] == LEAF_IDS["sky"]
    assert (leaf[1] == LEAF_IDS["road"]).all()
    assert (leaf[0, 1:] == LEAF_IDS["stop_line"]).all()


def test_every_leaf_survives_codes_and_heads() -> None:
    leaf = np.array([sorted(LEAF_IDS.values())], dtype=np.uint8)
    codes = leaf_to_codes(leaf)
    targets = head_targets(codes)
    scores = [
        np.where(t[None] == np.arange(len(h.classes))[:, None, None], 1.0, 0.0)
        for h, t in zip(HEADS, targets, strict=True)
    ]
    assert np.array_equal(decode_heads(scores), leaf)
    assert validate_heads(HEADS) == []


def _reference_decode(scores: list[np.ndarray]) -> np.ndarray:
    """Argmax down the tree, the plain way: ``np.argmax`` over the pixels each head governs."""
    current = np.array([NODE_CODES[c] for c in HEADS[0].classes], np.uint8)[scores[0].argmax(0)]
    for head, score in zip(HEADS[1:], scores[1:], strict=True):
        mask = current == NODE_CODES[head.parent]
        codes = np.array([NODE_CODES[c] for c in head.classes], np.uint8)
        current[mask] = codes[np.argmax(score[:, mask], axis=0)]
    return codes_to_leaf(current)


@pytest.mark.parametrize("seed", range(4))
def test_fast_decode_equals_plain_argmax_down_the_tree(seed: int) -> None:
    rng = np.random.default_rng(seed)
    scores = [rng.normal(size=(len(h.classes), 37, 53)).astype(np.float32) for h in HEADS]
    if seed % 2:  # ties everywhere: the first of the largest wins, as np.argmax
        scores = [np.round(s) for s in scores]
    scores[0][2] += seed  # from mixed to mostly `support`
    assert np.array_equal(decode_heads(scores), _reference_decode(scores))
    for score in scores:
        assert np.array_equal(argmax_channels(score), score.argmax(0))
