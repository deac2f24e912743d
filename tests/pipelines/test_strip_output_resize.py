"""`pipelines/strip_output_resize.py`: the graph without its Resize decodes to the same leaf ids."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.scene.adapters.heads import HEADS, decode_heads
from superlane_tools.scene.model_card import InputSpec
from superlane_tools.scene.onnx_backend import upsample_scores

onnx = pytest.importorskip("onnx")
torch = pytest.importorskip("torch")
ort = pytest.importorskip("onnxruntime")

SCRIPT = Path(__file__).resolve().parents[2] / "pipelines" / "strip_output_resize.py"


def test_stripped_graph_decodes_like_the_full_one(tmp_path: Path) -> None:
    from superlane_tools.training.export import export_onnx
    from superlane_tools.training.seg_net import HierarchicalSegNet

    strip_tail = runpy.run_path(str(SCRIPT))["strip_tail"]
    torch.manual_seed(0)
    names = [h.name for h in HEADS]
    full = tmp_path / "full.onnx"
    export_onnx(HierarchicalSegNet(), (1, 3, 96, 160), full, "image", names)  # the old export
    model = onnx.load(str(full))
    resizes = sum(n.op_type == "Resize" for n in model.graph.node)  # the decoder's too
    assert strip_tail(model)
    assert sum(n.op_type == "Resize" for n in model.graph.node) == resizes - 1
    producer = {o: n.op_type for n in model.graph.node for o in n.output}
    split = next(n for n in model.graph.node if n.op_type == "Split")
    assert producer[split.input[0]] == "Conv"  # the classifier
    assert not strip_tail(model)  # nothing left to strip
    onnx.checker.check_model(model)
    x = np.random.default_rng(0).normal(size=(1, 3, 96, 160)).astype(np.float32)
    before = ort.InferenceSession(str(full), providers=["CPUExecutionProvider"])
    after = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    ref = before.run(names, {"image": x})
    raw = after.run(names, {"image": x})
    assert {r.shape[2:] for r in raw} == {(48, 80)}
    got = upsample_scores(raw, InputSpec("image", 160, 96))
    for a, b in zip(ref, got, strict=True):
        assert np.abs(a[0] - b).max() < 1e-4
    assert np.array_equal(decode_heads([r[0] for r in ref]), decode_heads(got))
