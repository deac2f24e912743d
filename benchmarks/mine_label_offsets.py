"""Where ``slt mine``'s pre-annotations land: label points against a drive's ground-truth lines.

Run: ``python benchmarks/mine_label_offsets.py RUN TRUTH.tusimple.json [--out JSON]``

RUN is a ``slt reprocess`` run of a simulated drive (``slt simulate`` writes the truth file
beside the recording, lines at the recorded size). For every frame with a fit, the frame's
TuSimple pre-annotation is drawn twice with ``fleet.label_export.pre_annotation``: at the
recorded size (what ``slt mine`` writes) and at the processing size the fit ran at
(``lanes.parquet``'s ``width`` / ``height``: what it wrote before, on a JPEG saved at the
recorded size). Each label point is compared with the nearest truth line on the same row of the
recorded image (pixels); the medians and 95th percentiles of both go to stdout (and ``--out``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.camera.model import CameraModel
from superlane_tools.evaluation.tusimple import load_jsonl
from superlane_tools.fleet import find_drives
from superlane_tools.fleet.label_export import pre_annotation
from superlane_tools.reporting.layout import RunLayout


def offsets(
    lanes: list[list[float]], rows: list[float], truth: list[dict[int, float]]
) -> list[float]:
    """|x - truth x| of every label point (pixels), against the truth line nearest each lane.

    ``truth``: one ``row -> x`` mapping per truth line (rows of the recorded image).
    """
    out: list[float] = []
    for xs in lanes:
        best: list[float] | None = None
        for gt in truth:
            pairs = [(x, gt.get(round(y), -2.0)) for x, y in zip(xs, rows, strict=True)]
            d = [abs(x - t) for x, t in pairs if x >= 0 and t >= 0]
            if d and (best is None or np.median(d) < np.median(best)):
                best = d
        out += best or []
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("run", type=Path)
    ap.add_argument("truth", type=Path)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    drive = find_drives(args.run).drives[0]
    camera = CameraModel.from_dict(drive.provenance["config"]["resolved"]["camera"])
    records = {int(Path(r.raw_file).stem): r for r in load_jsonl(args.truth)}
    source = (camera.width, camera.height)
    fits = pd.read_parquet(RunLayout(args.run).lanes)
    found: dict[str, list[float]] = {"source": [], "processing": []}
    frames = 0
    for row in fits.to_dict("records"):
        truth = records.get(int(row["frame_index"]))
        if truth is None:
            continue
        gt = [
            {round(h): x for h, x in zip(truth.h_samples, lane, strict=True)}
            for lane in truth.lanes
        ]
        processed = (int(row["width"]), int(row["height"]))
        for name, size in (("source", source), ("processing", processed)):
            record, _ = pre_annotation(row, camera, "x.jpg", size)
            found[name] += offsets(record.lanes, record.h_samples, gt)
        frames += 1
    summary = {
        "run": str(args.run),
        "frames": frames,
        "source_size": list(source),
        **{
            f"{name}_{stat}": round(float(fn(np.asarray(v))), 2) if v else None
            for name, v in found.items()
            for stat, fn in (("median_px", np.median), ("p95_px", lambda a: np.percentile(a, 95)))
        },
        **{f"{name}_points": len(v) for name, v in found.items()},
    }
    print(json.dumps(summary, indent=1))
    if args.out is not None:
        args.out.write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
