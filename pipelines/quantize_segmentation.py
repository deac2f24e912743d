"""Build the shipped INT8 segmentation model (``super_seg_v2_int8``) from ``super_seg_v2``.

Static quantisation (:mod:`superlane_tools.training.quantize`, layout ``qdq_all``: u8
activations, s8 per-channel weights, MinMax) calibrated on the real TuSimple ``train_frames``
training split, every 3rd frame (33 frames; the 30 frames of the real-frame LaneEval are never
used). Writes ``MODEL.onnx`` and its card: the float model's card with the new name, sha256,
the quantisation settings, and the float model's metrics replaced by what ``--metrics`` (a YAML
mapping measured with ``pipelines/real_frames_eval.py``) holds. Deterministic for one
onnxruntime version (1.32.0 wrote the shipped file).

Usage::

    python pipelines/quantize_segmentation.py [--data ../shared/data] [--model super_seg_v2]
        [--out superlane_tools/models/super_seg_v2_int8.onnx] [--metrics metrics.yaml]
"""

from __future__ import annotations

import argparse
import hashlib
import os
from pathlib import Path

import onnxruntime
import yaml

from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.scene.model_card import load_card
from superlane_tools.scene.onnx_backend import resolve_model
from superlane_tools.training.quantize import quantize_model, tusimple_split

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    """Quantise the model and write it with its card."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument(
        "--data", type=Path, default=Path(os.environ.get("SLT_REALDATA", "../shared/data"))
    )
    ap.add_argument("--model", default="super_seg_v2")
    ap.add_argument("--layout", default="qdq_all")
    ap.add_argument(
        "--out", type=Path, default=REPO / "superlane_tools/models/super_seg_v2_int8.onnx"
    )
    ap.add_argument("--metrics", type=Path, default=None, help="YAML mapping of measured metrics")
    args = ap.parse_args()
    src, card_path = resolve_model(args.model)
    card = load_card(card_path).to_dict()
    calibration = tusimple_split(args.data, "train")[::3]
    quantize_model(src, args.out, calibration, load_card(card_path).input, args.layout)
    name = args.out.name.removesuffix(".onnx")
    card["name"] = name
    card["sha256"] = hashlib.sha256(args.out.read_bytes()).hexdigest()
    card["description"] = (
        f"Static INT8 quantisation of {args.model} ({args.layout}: u8 activations, s8 per-channel "
        f"weights, MinMax), calibrated on {len(calibration)} real TuSimple frames. Opt-in "
        f"(--model {name}); see metrics for its real-frame LaneEval against the float model. "
        f"Float model: " + str(card.get("description", ""))
    )
    card["quantization"] = {
        "source_model": args.model,
        "source_sha256": hashlib.sha256(Path(src).read_bytes()).hexdigest(),
        "layout": args.layout,
        "calibration": f"tusimple/train_frames train split, every 3rd frame ({len(calibration)})",
        "onnxruntime_version": onnxruntime.__version__,
        "command": f"python pipelines/quantize_segmentation.py --model {args.model} "
        f"--layout {args.layout}",
    }
    card["metrics"] = yaml.safe_load(args.metrics.read_text()) if args.metrics else {}
    card["ms_per_frame"] = {}
    card_out = args.out.with_name(f"{name}.card.yaml")
    write_text_atomic(card_out, yaml.safe_dump(card, sort_keys=False, width=100))
    print(f"wrote {args.out} ({card['sha256']}) and {card_out}")


if __name__ == "__main__":
    main()
