"""Benchmark the scene networks with onnxruntime on CPU, beside a conv-only baseline.

For each model (the shipped ones by default, or the architectures freshly initialised when no
model is shipped) the median milliseconds per frame at its input size are measured, together with
a baseline graph of the same input size in the same run: a single 3x3 convolution to 16
channels (the cheapest useful layer: it bounds the cost of reading the input and writing a
feature map). The ratio model / baseline is comparable across machines.

Usage:
    python benchmarks/bench_models.py [--threads 1 2] [--repeats 30] [--out FILE.json]
        [--compare-segmentation OTHER.onnx]

``--variants NAME@WxH ...`` times UNTRAINED exported segmentation variants (``slt train --arch``)
against a reference graph (``--reference``, default the shipped ``super_seg_v4``) and a 3x3 conv
baseline at each input size, all in one process, interleaved in rounds (the median of the
rounds' medians), and writes a table (``--out``, e.g. benchmarks/results/models_variants.json):

    nice -n 10 python benchmarks/bench_models.py --threads 1 --variants lite0@512x288 \\
        lite0@512x160 lite0-slim@512x160 lite0-s16@512x160 \\
        --out benchmarks/results/models_variants.json

``--compare-segmentation`` times another segmentation graph of the same input size in the same
run, e.g. the shipped one before ``pipelines/strip_output_resize.py``
(``git show 6d1a287:superlane_tools/models/super_seg_v2.onnx > before.onnx``).

On a shared machine, several threads can be slower than one (they wait for each other); both
are measured and reported, with the load average at the start.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

TARGET_MS = {"segmentation": 25.0, "corridor": 30.0}
"""Budgets, ms per frame on one thread (issue 25: segmentation <= 25 ms)."""


def _session(path: Path, threads: int) -> Any:
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def _median_ms(session: Any, tensor: np.ndarray, repeats: int, upsample: bool = False) -> float:
    """Median ms of one run; ``upsample``: plus the segmentation logits' upsampling."""
    from superlane_tools.scene.model_card import InputSpec
    from superlane_tools.scene.onnx_backend import upsample_scores

    name = session.get_inputs()[0].name
    spec = InputSpec(name, tensor.shape[3], tensor.shape[2])

    def run() -> None:
        outputs = session.run(None, {name: tensor})
        if upsample:
            upsample_scores(outputs, spec)

    for _ in range(3):
        run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(1000.0 * (time.perf_counter() - start))
    return statistics.median(times)


def _export(model: Any, shape: tuple[int, ...], path: Path, outputs: list[str]) -> None:
    from superlane_tools.training.export import export_onnx

    export_onnx(model, shape, path, "image", outputs)


def _baseline(shape: tuple[int, ...], path: Path) -> None:
    import torch

    _export(torch.nn.Conv2d(shape[1], 16, 3, padding=1), shape, path, ["features"])


def _model_file(task: str, scratch: Path) -> tuple[Path, str, tuple[int, ...]]:
    from superlane_tools.models import MODELS_DIR
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import (
        DEFAULT_CORRIDOR_MODEL,
        DEFAULT_SEGMENTATION_MODEL,
    )

    name = DEFAULT_SEGMENTATION_MODEL if task == "segmentation" else DEFAULT_CORRIDOR_MODEL
    shipped = MODELS_DIR / f"{name}.onnx"
    if shipped.is_file():
        card = load_card(MODELS_DIR / f"{name}.card.yaml")
        return shipped, f"shipped {name}", card.input.shape
    from superlane_tools.scene.adapters.heads import HEADS
    from superlane_tools.training.corridor_net import EgoCorridorNet
    from superlane_tools.training.seg_net import HalfResolutionHeads, HierarchicalSegNet

    if task == "segmentation":
        shape: tuple[int, ...] = (1, 3, 288, 512)
        net: Any = HalfResolutionHeads(HierarchicalSegNet())
        outputs = [h.name for h in HEADS]
    else:
        shape, net, outputs = (1, 1, 360, 652), EgoCorridorNet(), ["corridor"]
    path = scratch / f"{task}.onnx"
    _export(net, shape, path, outputs)
    return path, f"untrained {task} architecture (no shipped model)", shape


def _variant(text: str, scratch: Path) -> tuple[Path, tuple[int, ...], int]:
    """Export the untrained variant ``NAME@WxH``; return its file, input shape and parameters."""
    from superlane_tools.scene.adapters.heads import HEADS
    from superlane_tools.training.lite_seg_net import (
        LiteHalfResolutionHeads,
        LiteHierarchicalSegNet,
        check_input_size,
    )

    name, _, size = text.partition("@")
    width, height = (int(v) for v in (size or "512x288").split("x"))
    check_input_size(width, height, name)
    net = LiteHierarchicalSegNet(pretrained=False, variant=name)
    params = sum(p.numel() for p in net.parameters())
    shape = (1, 3, height, width)
    path = scratch / f"{name}_{width}x{height}.onnx"
    _export(LiteHalfResolutionHeads(net), shape, path, [h.name for h in HEADS])
    return path, shape, params


def _variants_table(args: argparse.Namespace) -> dict[str, Any]:
    """Time the variants, the reference and the baselines in rounds, one session each."""
    threads = args.threads[0]
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        ref = args.reference
        import onnx

        dims = onnx.load(str(ref)).graph.input[0].type.tensor_type.shape.dim
        ref_shape = tuple(int(d.dim_value) for d in dims)
        jobs = [(ref.stem, ref, ref_shape, _card_parameters(ref))]
        for text in args.variants:
            path, shape, params = _variant(text, scratch)
            jobs.append((text, path, shape, params))
        for shape in sorted({job[2] for job in jobs}):
            name = f"conv3x3@{shape[3]}x{shape[2]}"
            _baseline(shape, scratch / f"{name}.onnx")
            jobs.append((name, scratch / f"{name}.onnx", shape, None))
        sessions = [_session(job[1], threads) for job in jobs]
        tensors = [np.random.default_rng(0).normal(size=job[2]).astype(np.float32) for job in jobs]
        times: list[list[float]] = [[] for _ in jobs]
        for _ in range(args.rounds):
            for i, job in enumerate(jobs):
                upsample = not job[0].startswith("conv3x3")
                times[i].append(_median_ms(sessions[i], tensors[i], args.repeats, upsample))
        ms = [statistics.median(t) for t in times]
    base = {job[2]: ms[i] for i, job in enumerate(jobs) if job[0].startswith("conv3x3")}
    for i, (name, _, shape, params) in enumerate(jobs):
        rows.append(
            {
                "variant": name,
                "input": f"{shape[3]}x{shape[2]}",
                "params": params,
                "median_ms": round(ms[i], 2),
                "ratio_to_reference": round(ms[i] / ms[0], 3),
                "ratio_to_conv3x3": round(ms[i] / base[shape], 2),
            }
        )
        print(f"{name:24s} {shape[3]}x{shape[2]} {ms[i]:7.2f} ms  x{ms[i] / ms[0]:.2f} ref")
    return {"reference": ref.name, "threads": threads, "rounds": args.rounds, "rows": rows}


def _card_parameters(path: Path) -> int | None:
    from superlane_tools.errors import SltError
    from superlane_tools.scene.model_card import card_path_for, load_card

    try:
        return int(load_card(card_path_for(path)).parameters)
    except (SltError, TypeError, ValueError):
        return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/models.json"))
    ap.add_argument("--compare-segmentation", type=Path, default=None, metavar="ONNX")
    ap.add_argument("--variants", nargs="+", default=None, metavar="NAME@WxH")
    ap.add_argument("--reference", type=Path, default=None, metavar="ONNX")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    results: dict[str, Any] = {
        "machine": f"{platform.machine()} {os.cpu_count()} cpus",
        "load_average_1min": round(os.getloadavg()[0], 2),
        "runtime": "onnxruntime CPUExecutionProvider, batch 1, network only (segmentation: "
        "plus the upsampling of its logits to the input size, which its graph leaves to the "
        "runtime)",
        "models": {},
    }
    if args.variants:
        from superlane_tools.models import MODELS_DIR

        args.reference = args.reference or MODELS_DIR / "super_seg_v4.onnx"
        results.pop("models")
        results["runtime"] = results["runtime"].replace("network only", "untrained variants")
        results["command"] = "python benchmarks/bench_models.py " + " ".join(sys.argv[1:])
        results["variants"] = _variants_table(args)
        results["load_average_1min_end"] = round(os.getloadavg()[0], 2)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
        print(f"wrote {args.out}")
        return
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        jobs = [(task, task, *_model_file(task, scratch)) for task in ("segmentation", "corridor")]
        if args.compare_segmentation is not None:
            other = args.compare_segmentation
            jobs.insert(1, ("segmentation_compared", "segmentation", other, str(other), jobs[0][4]))
        for key, task, path, what, shape in jobs:
            tensor = np.random.default_rng(0).normal(size=shape).astype(np.float32)
            _baseline(shape, scratch / f"{task}_baseline.onnx")
            entry: dict[str, Any] = {
                "model": what,
                "input": f"{shape[3]}x{shape[2]}x{shape[1]}",
                "target_ms": TARGET_MS[task],
            }
            for threads in args.threads:
                model_ms = _median_ms(
                    _session(path, threads), tensor, args.repeats, task == "segmentation"
                )
                base_ms = _median_ms(
                    _session(scratch / f"{task}_baseline.onnx", threads), tensor, args.repeats
                )
                entry[f"threads_{threads}"] = {
                    "median_ms": round(model_ms, 2),
                    "baseline_conv3x3_ms": round(base_ms, 2),
                    "ratio_to_baseline": round(model_ms / base_ms, 2),
                    "meets_target": model_ms <= TARGET_MS[task],
                }
                print(f"{task} {threads}t: {model_ms:.1f} ms (baseline {base_ms:.1f} ms) {what}")
            results["models"][key] = entry
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
