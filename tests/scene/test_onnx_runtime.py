"""ONNX runtimes: carded models load, run and decode; mismatching models are refused."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.scene import SegmentationBackend
from superlane_tools.scene.corridor_runtime import CorridorSmoother, OnnxCorridorModel
from superlane_tools.scene.model_card import InputSpec, card_path_for, load_card
from superlane_tools.scene.model_errors import ModelError
from superlane_tools.scene.onnx_backend import (
    DEFAULT_CORRIDOR_MODEL,
    DEFAULT_SEGMENTATION_MODEL,
    OnnxSegmentationBackend,
    preprocess,
    resolve_model,
    upsample_scores,
)
from superlane_tools.training.toy_dataset import toy_frame, write_toy_dataset
from superlane_tools.training.train import TrainParams, train


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("onnx_models")
    data = write_toy_dataset(root / "data", frames=2, width=96, height=48)
    out = {}
    for task in ("segmentation", "corridor"):
        params = TrainParams(task, data, root / f"{task}.onnx", epochs=1, batch=2, size=(64, 32))
        out[task] = train(params).model_path
    return out


def _copy(model: Path, folder: Path) -> Path:
    target = folder / model.name
    shutil.copy(model, target)
    shutil.copy(card_path_for(model), card_path_for(target))
    return target


def test_segmentation_backend_returns_leaf_ids_at_image_size(models: dict[str, Path]) -> None:
    backend = OnnxSegmentationBackend(models["segmentation"])
    assert isinstance(backend, SegmentationBackend)
    image, _, _ = toy_frame(np.random.default_rng(0), 150, 70)
    labels = backend.segment(image)
    assert labels.shape == (70, 150)
    assert labels.dtype == np.uint8
    assert set(np.unique(labels)) <= set(LEAF_IDS.values())
    assert len(backend.segment_batch([image, image])) == 2
    assert backend.name == "onnx:segmentation"
    assert len(backend.sha256) == 64


def test_corridor_runtime_and_smoother(models: dict[str, Path]) -> None:
    runtime = OnnxCorridorModel(models["corridor"])
    image, _, _ = toy_frame(np.random.default_rng(1), 130, 72)
    prob = runtime.probability(image)
    assert prob.shape == (72, 130)
    assert prob.dtype == np.float32
    assert 0.0 <= prob.min() <= prob.max() <= 1.0
    smoother = CorridorSmoother(3)
    frames = [np.full((2, 2), v, np.float32) for v in (0.0, 0.3, 0.6, 0.9)]
    outs = [smoother.update(f) for f in frames]
    assert outs[0][0, 0] == pytest.approx(0.0)
    assert outs[1][0, 0] == pytest.approx(0.15)
    assert outs[3][0, 0] == pytest.approx(0.6)  # mean of the last three frames only


def test_tampered_model_is_refused(models: dict[str, Path], tmp_path: Path) -> None:
    model = _copy(models["segmentation"], tmp_path)
    with model.open("ab") as handle:
        handle.write(b"\0")
    with pytest.raises(ModelError, match="does not match its card: sha256"):
        OnnxSegmentationBackend(model)


def test_card_with_wrong_io_is_refused(models: dict[str, Path], tmp_path: Path) -> None:
    model = _copy(models["segmentation"], tmp_path)
    card_file = card_path_for(model)
    data = yaml.safe_load(card_file.read_text(encoding="utf-8"))
    data["input"]["width"] = 128
    card_file.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ModelError, match="input shape"):
        OnnxSegmentationBackend(model)
    data["input"]["width"] = 64
    data["outputs"][0]["name"] = "logits"
    card_file.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ModelError, match="not a model output"):
        OnnxSegmentationBackend(model)


def test_missing_card_wrong_task_unknown_name(models: dict[str, Path], tmp_path: Path) -> None:
    lonely = tmp_path / "lonely.onnx"
    shutil.copy(models["corridor"], lonely)
    with pytest.raises(ModelError, match="model card not found"):
        OnnxCorridorModel(lonely)
    with pytest.raises(ModelError, match="is a corridor model"):
        OnnxSegmentationBackend(models["corridor"])
    with pytest.raises(ModelError, match="unknown model 'no_such_model'"):
        resolve_model("no_such_model")


def test_card_rejects_heads_off_the_hierarchy(models: dict[str, Path], tmp_path: Path) -> None:
    model = _copy(models["segmentation"], tmp_path)
    card_file = card_path_for(model)
    data = yaml.safe_load(card_file.read_text(encoding="utf-8"))
    data["outputs"][3]["classes"][0] = "sky"  # sky is not below drivable
    card_file.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ModelError, match="not below 'drivable'"):
        load_card(card_file)


def test_shipped_models_match_their_cards() -> None:
    backend = OnnxSegmentationBackend()  # the default model, verified against its card
    assert backend.card.name == DEFAULT_SEGMENTATION_MODEL == "super_seg_v4"
    assert backend.card.input.shape == (1, 3, 288, 512)
    image, _, _ = toy_frame(np.random.default_rng(5), 320, 180)
    assert backend.segment(image).shape == (180, 320)
    runtime = OnnxCorridorModel()  # the default corridor model
    assert runtime.card.name == DEFAULT_CORRIDOR_MODEL == "ego_corridor_v3"
    assert runtime.card.input.shape == (1, 1, 360, 652)
    assert runtime.card.parameters < 1_000_000
    assert runtime.probability(image).shape == (180, 320)


@pytest.mark.parametrize(
    "model",
    [
        "super_seg_v1",
        "super_seg_v2",
        "super_seg_v3",
        "super_seg_v4",
        "super_seg_v5",
        "super_seg_v7",
        "super_seg_v8",
    ],
)
def test_shipped_segmentation_graphs_stop_at_half_resolution(model: str) -> None:
    backend = OnnxSegmentationBackend(model)
    outputs = backend.model.session.get_outputs()
    heads = backend.card.heads()
    assert [o.name for o in outputs] == [h.name for h in heads]
    assert [o.shape[1] for o in outputs] == [len(h.classes) for h in heads]
    image, _, _ = toy_frame(np.random.default_rng(2), 640, 360)
    raw = backend.model.session.run(None, {"image": preprocess(image, backend.card.input)})
    height, width = backend.card.input.height, backend.card.input.width
    stride = 4 if backend.card.training.get("architecture") == "lite0-s16" else 2  # heads at 1/4
    assert {r.shape[2:] for r in raw} == {(height // stride, width // stride)}  # upsampled later
    assert {s.shape[1:] for s in backend.scores(image)} == {(height, width)}


def test_upsample_scores_is_torch_bilinear_interpolation() -> None:
    import torch
    import torch.nn.functional as F  # noqa: N812

    rng = np.random.default_rng(4)
    outputs = [rng.normal(size=(1, c, 18, 32)).astype(np.float32) for c in (3, 5)]
    spec = InputSpec("image", 64, 36)
    got = upsample_scores(outputs, spec)
    for out, head in zip(outputs, got, strict=True):
        ref = F.interpolate(
            torch.from_numpy(out), size=(36, 64), mode="bilinear", align_corners=False
        )
        assert head.shape == (out.shape[1], 36, 64)
        assert np.abs(head - ref[0].numpy()).max() < 1e-5
    full = [rng.normal(size=(1, 3, 36, 64)).astype(np.float32)]
    assert np.array_equal(upsample_scores(full, spec)[0], full[0][0])  # already at input size


def test_shipped_segmentation_on_a_real_frame(realdata: Path) -> None:
    import cv2

    image = cv2.imread(str(realdata / "tusimple" / "frames" / "0000.png"), cv2.IMREAD_COLOR)
    labels = OnnxSegmentationBackend().segment(image)
    assert labels.shape == image.shape[:2]
    bottom = labels[600:, 400:880]  # the road ahead of the car
    assert np.mean(bottom == LEAF_IDS["road"]) > 0.5


@pytest.mark.parametrize(
    ("order", "mean", "std"),
    [
        ("RGB", (0.45, 0.45, 0.45), (0.25, 0.25, 0.25)),
        ("BGR", (0.1, 0.2, 0.3), (0.3, 0.2, 0.7)),
        ("GRAY", (0.37,), (0.71,)),
    ],
)
def test_preprocess_equals_the_normalisation_formula(
    order: str, mean: tuple[float, ...], std: tuple[float, ...]
) -> None:
    import cv2

    image = np.random.default_rng(3).integers(0, 256, (90, 160, 3), dtype=np.uint8)
    spec = InputSpec("image", 64, 36, order, mean, std)
    resized = cv2.resize(image, (64, 36), interpolation=cv2.INTER_AREA)
    if order == "GRAY":
        pixels = cv2.cvtColor(resized, cv2.COLOR_BGR2GRAY)[:, :, None]
    else:
        pixels = resized[:, :, ::-1] if order == "RGB" else resized
    m, s = np.asarray(mean, np.float32), np.asarray(std, np.float32)
    expected = ((pixels.astype(np.float32) / 255.0 - m) / s).transpose(2, 0, 1)[None]
    tensor = preprocess(image, spec)
    assert tensor.dtype == np.float32
    assert tensor.flags.c_contiguous
    assert np.array_equal(tensor, expected)  # bit for bit: the table holds the same float32 ops
