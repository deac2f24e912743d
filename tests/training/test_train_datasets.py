"""Heterogeneous training data: readers on the real data, palette labels, dataset entries."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from superlane_tools.scene.adapters.heads import NODE_CODES
from superlane_tools.scene.adapters.loader import load_adapter
from superlane_tools.training.datasets import (
    TUSIMPLE_VAL_FRAMES,
    DatasetSpec,
    head_level,
    load_dataset_list,
    load_set,
    parse_data_arg,
)
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.label_io import read_label_ids
from superlane_tools.training.tusimple_targets import CORRIDOR_IGNORE

VISTAS_IDS = [13, 24, 55, 27]


def _palette_png(path: Path, ids: list[int]) -> None:
    """Write a real 8-bit palette PNG whose palette colours differ from the indices."""
    image = Image.fromarray(np.array([ids, ids[::-1]], np.uint8), mode="P")
    rng = np.random.default_rng(0)
    image.putpalette(rng.integers(0, 256, 768, dtype=np.uint8).tolist())
    image.save(path)


def test_palette_png_reads_indices_not_colours(tmp_path: Path) -> None:
    path = tmp_path / "label.png"
    _palette_png(path, VISTAS_IDS)
    with Image.open(path) as check:
        assert check.mode == "P"
    assert read_label_ids(path).tolist() == [VISTAS_IDS, VISTAS_IDS[::-1]]


def test_vistas_index_folder_maps_palette_ids(tmp_path: Path) -> None:
    import cv2

    (tmp_path / "img").mkdir()
    (tmp_path / "lab").mkdir()
    cv2.imwrite(str(tmp_path / "img" / "a.png"), np.full((2, 4, 3), 90, np.uint8))
    _palette_png(tmp_path / "lab" / "a.png", VISTAS_IDS)
    pd.DataFrame({"image": ["img/a.png"], "labels": ["lab/a.png"]}).to_parquet(
        tmp_path / "index.parquet"
    )
    loaded = load_set(DatasetSpec("mapillary_vistas", tmp_path), "segmentation", (4, 2))
    assert loaded.codes is not None
    expected = load_adapter("mapillary_vistas").to_codes(np.array([VISTAS_IDS] * 2, np.uint8))
    assert loaded.codes[0, 0].tolist() == expected[0].tolist()
    assert NODE_CODES["road"] in loaded.codes  # id 13 = construction--flat--road


def test_parse_data_arg_and_yaml_list(tmp_path: Path) -> None:
    assert parse_data_arg("tusimple=/d/t") == DatasetSpec("tusimple", Path("/d/t"))
    assert parse_data_arg("camvid:0.5=/d/c").weight == 0.5
    assert parse_data_arg("/d/sim") == DatasetSpec("sim", Path("/d/sim"))
    with pytest.raises(TrainingError, match="weight"):
        parse_data_arg("camvid:x=/d/c")
    listing = tmp_path / "data.yaml"
    listing.write_text(
        "datasets:\n  - {reader: camvid, folder: cv, weight: 2, levels: [1, 2]}\n"
        "  - {reader: tusimple, folder: /abs/t, split: val}\n",
        encoding="utf-8",
    )
    specs = load_dataset_list(listing)
    assert specs[0] == DatasetSpec("camvid", tmp_path / "cv", 2.0, "train", (1, 2))
    assert specs[1].split == "val"
    listing.write_text("datasets:\n  - {reader: camvid, folder: x, split: test}\n", "utf-8")
    with pytest.raises(TrainingError, match="split"):
        load_dataset_list(listing)
    listing.write_text("datasets:\n  - {reader: tusimple, folder: t, expand_m: 0.5}\n", "utf-8")
    assert load_dataset_list(listing)[0].expand_m == 0.5
    listing.write_text("datasets:\n  - {reader: camvid, folder: c, expand_m: 0.5}\n", "utf-8")
    with pytest.raises(TrainingError, match="expand_m"):
        load_dataset_list(listing)


def test_tusimple_reader_on_real_frames(realdata: Path) -> None:
    folder = realdata / "tusimple" / "train_frames"
    val = load_set(DatasetSpec("tusimple", folder, split="val"), "segmentation", (512, 288))
    train = load_set(DatasetSpec("tusimple", folder, split="train", levels=None), "corridor",
                     (652, 360), max_frames=3)  # fmt: skip
    assert len(val.names) == TUSIMPLE_VAL_FRAMES
    assert not set(val.names) & set(train.names)
    assert val.codes is not None
    assert train.corridor is not None
    codes = val.codes[0]
    marking = codes == NODE_CODES["lane_marking"]
    assert marking.any()
    assert (codes == NODE_CODES["road"]).any()
    assert (codes == 0).any()
    # paint gets wider towards the bottom of the image
    rows = np.nonzero(marking.any(axis=1))[0]
    top, bottom = rows.min(), rows.max()
    assert marking[bottom - 5].sum() > 2 * marking[top + 5].sum()
    corridor = train.corridor[0]
    assert set(np.unique(corridor)) == {0, 1, CORRIDOR_IGNORE}
    assert (corridor[-1] == 1).any()
    assert (corridor[0] == CORRIDOR_IGNORE).all()


def test_tusimple_expansion_labels_the_shoulder_next_to_the_outer_lines(realdata: Path) -> None:
    folder = realdata / "tusimple" / "train_frames"
    size = (512, 288)
    plain = load_set(DatasetSpec("tusimple", folder, split="val"), "segmentation", size, 4)
    wide = load_set(
        DatasetSpec("tusimple", folder, split="val", expand_m=0.6), "segmentation", size, 4
    )
    assert plain.codes is not None
    assert wide.codes is not None
    road, marking = NODE_CODES["road"], NODE_CODES["lane_marking"]
    # The markings are the same; void next to the outer lines becomes road, nothing else changes.
    np.testing.assert_array_equal(wide.codes == marking, plain.codes == marking)
    changed = wide.codes != plain.codes
    assert changed.any()
    assert (plain.codes[changed] == 0).all()
    assert (wide.codes[changed] == road).all()
    # The band is narrow: a small share of the void becomes road.
    assert changed.sum() < 0.2 * (plain.codes == 0).sum()


def test_camvid_reader_trains_levels_one_and_two_only(realdata: Path) -> None:
    loaded = load_set(
        DatasetSpec("camvid", realdata / "camvid", split="val"), "segmentation", (512, 288), 4
    )
    assert loaded.codes is not None
    assert loaded.images.shape[1:3] == (288, 384)
    present = set(np.unique(loaded.codes).tolist())
    assert NODE_CODES["drivable"] in present
    assert NODE_CODES["sky"] in present
    assert NODE_CODES["road"] not in present
    assert NODE_CODES["lane_marking"] not in present
    with pytest.raises(TrainingError, match="ego-lane"):
        load_set(DatasetSpec("camvid", realdata / "camvid"), "corridor", (64, 36), 1)
    masked = load_set(
        DatasetSpec("camvid", realdata / "camvid", split="val", levels=(1,)),
        "segmentation",
        (64, 48),
        1,
    )
    assert masked.heads == tuple(head_level(i) == 1 for i in range(len(masked.heads)))
