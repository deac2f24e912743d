"""Score segmentation models on the in-loop real dev sets, the way training validates.

Usage::

    python pipelines/dev_scores.py super_seg_v4 super_seg_v5 \\
        runs/train_models/models/super_seg_v6.onnx [--data ../shared/data]

Each model (a shipped name or an ONNX file with its card) segments the real dev frames of
``superlane_tools.training.validation`` (TuSimple dev, CULane driver 161 and night, CamVid val;
never trained on); a model trained in the canonical camera runs in it, as in training. Prints
one line of scores per model (lane-marking F; CamVid level-2 mIoU).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    """Print each model's dev-set scores as one JSON line."""
    from superlane_tools.training.validation import PROTOCOL, real_dev_sets, reference_scores

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="+")
    default = os.environ.get("SLT_REALDATA", str(Path(__file__).parents[2] / "shared" / "data"))
    ap.add_argument("--data", type=Path, default=Path(default))
    args = ap.parse_args(argv)
    sets = real_dev_sets(args.data)
    for model in args.models:
        scores = reference_scores(model, sets)  # as the runtime runs it, as training validates
        print(json.dumps({"model": model, "protocol": PROTOCOL, "scores": scores}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
