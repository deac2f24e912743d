"""Does INT8 make the shipped segmentation network faster? Static quantisation on real frames.

Usage::

    python benchmarks/bench_quantize.py [--model super_seg_v2] [--data ../shared/data]
        [--repeats 20] [--keep DIR] [--out benchmarks/results/quantize.json]

Quantises the shipped model with ``onnxruntime.quantization.quantize_static`` (u8 activations,
s8 per-channel weights, MinMax calibration) in three layouts -- QDQ over every operator, QDQ over
the convolutions only, QOperator over the convolutions and concatenations -- calibrated on the
real TuSimple ``train_frames`` training split (the 99 frames before the 30 held out for the
real-frame LaneEval, every 3rd: 33 frames), preprocessed exactly as ``slt reprocess`` does
(decoded, resized to 640 wide, then the card's resize and normalisation). Then it times every
variant beside the float model in the same process, interleaved, one onnxruntime thread each (as
``slt reprocess`` runs them), and reports the thread-CPU milliseconds per inference (medians),
the ratio to the float model, the file sizes and sha256, and how many pixels' leaf classes
change on the 30 held-out frames.

``--keep DIR`` keeps the quantised files (e.g. for ``pipelines/real_frames_eval.py``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results" / "quantize.json"


def _session(path: Path) -> Any:
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.log_severity_level = 3
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def _leaf(session: Any, tensor: np.ndarray, card: Any) -> np.ndarray:
    from superlane_tools.scene.adapters.heads import decode_heads
    from superlane_tools.scene.onnx_backend import upsample_scores

    heads = card.heads()
    outputs = session.run([h.name for h in heads], {card.input.name: tensor})
    return decode_heads(upsample_scores(outputs, card.input), heads)


def main() -> None:
    """Quantise, time and compare; write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model", default="super_seg_v2")
    parser.add_argument(
        "--data", type=Path, default=Path(os.environ.get("SLT_REALDATA", "../shared/data"))
    )
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--keep", type=Path, default=None, help="keep the quantised files here")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import resolve_model
    from superlane_tools.training.quantize import (
        LAYOUTS,
        network_input,
        quantize_model,
        tusimple_split,
    )

    src, card_path = resolve_model(args.model)
    card = load_card(card_path)
    calib = tusimple_split(args.data, "train")[::3]
    held_out = tusimple_split(args.data, "val")
    uptime = subprocess.run(["uptime"], capture_output=True, text=True, check=False).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        files = {"float32": src}
        for layout in LAYOUTS:
            files[layout] = folder / f"{args.model}_int8_{layout}.onnx"
            quantize_model(src, files[layout], calib, card.input, layout)
        sessions = {k: _session(p) for k, p in files.items()}
        tensors = [network_input(p, card.input) for p in held_out]
        times: dict[str, list[float]] = {k: [] for k in files}
        for s in sessions.values():
            for _ in range(3):
                s.run(None, {card.input.name: tensors[0]})
        for i in range(args.repeats):
            for key, s in sessions.items():
                start = time.thread_time()
                s.run(None, {card.input.name: tensors[i % len(tensors)]})
                times[key].append(1e3 * (time.thread_time() - start))
        reference = [_leaf(sessions["float32"], t, card) for t in tensors]
        result: dict[str, Any] = {
            "model": args.model,
            "uptime": uptime,
            "calibration": f"{len(calib)} real TuSimple train_frames (train split, every 3rd)",
            "held_out": f"{len(held_out)} real TuSimple train_frames (the LaneEval val split)",
            "runtime": "onnxruntime CPUExecutionProvider, 1 intra-op thread, ORT_ENABLE_ALL",
            "variants": {},
        }
        base_ms = statistics.median(times["float32"])
        for key, path in files.items():
            changed = [
                float(np.mean(_leaf(sessions[key], t, card) != r))
                for t, r in zip(tensors, reference, strict=True)
            ]
            ms = statistics.median(times[key])
            result["variants"][key] = {
                "cpu_ms_median": round(ms, 2),
                "ratio_to_float32": round(ms / base_ms, 3),
                "bytes": path.stat().st_size,
                "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                "leaf_pixels_changed_vs_float32": round(statistics.mean(changed), 4),
            }
            print(key, result["variants"][key], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
