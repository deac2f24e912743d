"""End the shipped segmentation graphs at their classifier: the runtime upsamples the logits.

The segmentation networks end with a 1x1 classifier at half the input resolution, a bilinear
``Resize`` (``half_pixel``) to the input size and a ``Split`` into the heads. onnxruntime runs
that tail in about 4 ms of the 18.7 ms per frame on one thread (the Resize on padded NCHWc
blocks, then a layout reorder and a copy per head); :func:`superlane_tools.scene.onnx_backend.
upsample_scores` does the same upsampling with OpenCV in 0.6-1.3 ms. This script rewires the
``Split`` to the ``Resize``'s input, removes the nodes left unused, and checks on real frames that
the decoded leaf ids are the same as the original graph's; then it writes the model and the
new sha256 into its card (both atomically). The weights are untouched.

Usage:
    python pipelines/strip_output_resize.py [--models super_seg_v1,super_seg_v2,super_seg_v3]
        [--data ../shared/data] [--frames 40]

Needs the ``train`` extra (``onnx``). A model whose graph has no such tail is left alone.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.reporting.atomic import atomic_path
from superlane_tools.scene.adapters.heads import decode_heads
from superlane_tools.scene.model_card import InputSpec, load_card
from superlane_tools.scene.onnx_backend import preprocess, resolve_model, upsample_scores


def strip_tail(model: Any) -> bool:
    """Rewire the heads' ``Split`` past a trailing bilinear ``Resize``; return False if none."""
    graph = model.graph
    producer = {out: node for node in graph.node for out in node.output}
    heads = {o.name for o in graph.output}
    split = next((n for n in graph.node if n.op_type == "Split" and heads & set(n.output)), None)
    resize = producer.get(split.input[0]) if split is not None else None
    if split is None or resize is None or resize.op_type != "Resize":
        return False
    attrs = {a.name: a for a in resize.attribute}
    if attrs["mode"].s != b"linear" or attrs["coordinate_transformation_mode"].s != b"half_pixel":
        raise SystemExit(f"unexpected Resize {resize.name}: only linear half_pixel is upsampled")
    split.input[0] = resize.input[0]
    used = set(heads)
    kept = []
    for node in reversed(graph.node):  # drop what no longer feeds an output
        if used & set(node.output):
            kept.append(node)
            used.update(i for i in node.input if i)
    del graph.node[:]
    graph.node.extend(reversed(kept))
    for output in graph.output:  # spatial size now that of the classifier
        dims = output.type.tensor_type.shape.dim
        for dim in dims[2:]:
            dim.Clear()
            dim.dim_param = "half"
    return True


def write_card_text(path: Path, old_sha: str, new_sha: str, note: str) -> None:
    """Put the new sha256 and a ``training.graph_tail`` note into the card, keeping its comments."""
    import yaml

    text = path.read_text(encoding="utf-8")
    if text.count(f"sha256: {old_sha}") != 1 or text.count("\ntraining:\n") != 1:
        raise SystemExit(f"{path}: cannot find its sha256 and training lines")
    line = yaml.safe_dump({"graph_tail": note}, width=100, allow_unicode=True)
    indented = "".join(f"  {row}\n" for row in line.splitlines())
    text = text.replace(f"sha256: {old_sha}", f"sha256: {new_sha}")
    text = text.replace("\ntraining:\n", f"\ntraining:\n{indented}")
    with atomic_path(path, suffix=".yaml") as tmp:
        tmp.write_text(text, encoding="utf-8")
    load_card(path)  # still a valid card


def _session(data: bytes) -> Any:
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.log_severity_level = 3
    return ort.InferenceSession(data, options, providers=["CPUExecutionProvider"])


def real_frames(data: Path, count: int) -> list[Path]:
    """Real frames: TuSimple train frames, then CamVid validation scenes."""
    tusimple = sorted((data / "tusimple" / "train_frames").rglob("*.jpg"))
    camvid = sorted((data / "camvid" / "val" / "images").glob("*.jpg"))
    frames = tusimple[: count // 2] + camvid[: count - count // 2]
    if not frames:
        raise SystemExit(f"no real frames under {data}: set --data or SLT_REALDATA")
    return frames


def differing_pixels(before: bytes, after: bytes, spec: InputSpec, frames: list[Path]) -> int:
    """Count the leaf-id pixels that differ between the two graphs on ``frames``."""
    import cv2

    old, new = _session(before), _session(after)
    names = [o.name for o in old.get_outputs()]
    differ = 0
    for path in frames:
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        tensor = preprocess(image, spec)
        ref = [o[0] for o in old.run(names, {spec.name: tensor})]
        got = upsample_scores(new.run(names, {spec.name: tensor}), spec)
        differ += int(np.count_nonzero(decode_heads(ref) != decode_heads(got)))
    return differ


def main() -> None:
    """Strip the tail of each model, check it on real frames, write model and card."""
    import onnx

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--models", default="super_seg_v1,super_seg_v2,super_seg_v3")
    parser.add_argument(
        "--data", type=Path, default=Path(os.environ.get("SLT_REALDATA", "../shared/data"))
    )
    parser.add_argument("--frames", type=int, default=40, help="real frames to compare on")
    args = parser.parse_args()
    frames = real_frames(args.data, args.frames)
    for name in args.models.split(","):
        path, card_path = resolve_model(name)
        card = load_card(card_path)
        before = path.read_bytes()
        model = onnx.load_from_string(before)
        if not strip_tail(model):
            print(f"{name}: no trailing Resize, left alone")
            continue
        onnx.checker.check_model(model)
        after = model.SerializeToString()
        differ = differing_pixels(before, after, card.input, frames)
        pixels = len(frames) * card.input.width * card.input.height
        print(f"{name}: {differ} of {pixels} leaf pixels differ on {len(frames)} real frames")
        if differ > pixels * 1e-5:
            sys.exit(f"{name}: too many pixels differ; model left alone")
        with atomic_path(path, suffix=".onnx") as tmp:
            tmp.write_bytes(after)
        note = (
            f"re-exported ({len(before)} -> {len(after)} bytes) by "
            "pipelines/strip_output_resize.py: the graph ends at the classifier (half resolution) "
            f"and the runtime upsamples the logits bilinearly; same weights; {differ} of {pixels} "
            f"leaf pixels differ on {len(frames)} real frames (TuSimple, CamVid); sha256 before "
            f"{card.sha256}"
        )
        digest = hashlib.sha256(after).hexdigest()
        write_card_text(card_path, card.sha256, digest, note)
        print(f"{name}: written, sha256 {digest}")


if __name__ == "__main__":
    main()
