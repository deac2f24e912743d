"""Real-frame end-to-end lane accuracy: TuSimple LaneEval on the real validation split, KITTI.

For each segmentation backend the documented CLI chain runs as subprocesses, exactly as a user
would type it:

```
slt segment FRAMES --out SEG --backend B --camera tusimple --overlay
slt lanes fit SEG --camera tusimple --out lanes.parquet
slt lanes export-tusimple lanes.parquet --camera tusimple --h-samples 160:720:10 \
    --out pred.json --raw-ext .png
slt eval tusimple pred.json DATA/tusimple/frames/labels.json --json
```

``FRAMES`` is the fixed real validation split, written as PNGs with one ``labels.json``: the last
30 frames of ``tusimple/train_frames`` (never trained on) and the 6 labelled frames of
``tusimple/frames``. ``--backends`` takes ``classical``, ``onnx`` or ``onnx=MODEL``. The same chain
with ``--camera kitti`` runs on KITTI ``um_000000``; the ego lane between the fitted ego-left and
ego-right lines, rasterised up to the shorter line's fitted range, is scored against
``gt_um_lane_000000.png`` (:mod:`superlane_tools.evaluation.kitti`). The four ``unlabeled/``
TuSimple frames go through segment + fit for the overlays only.

Besides the official score, the report gives the score with the ``run_time`` gate switched off
(LaneEval scores a frame 0 when its run time exceeds 200 ms) and the marking-pixel support of
the segmentation: recall = labelled lane points within 3 px of a predicted marking pixel,
precision = predicted marking pixels within 10 px of a labelled lane polyline.

Usage:
    python pipelines/real_frames_eval.py [--data ../shared/data] [--work DIR]
        [--backends classical,onnx] [--report reports/real_frames.md] [--json out.json]
        [--update-cards] [--reuse earlier.json]

``--reuse`` takes the backends found in an earlier run's ``--json`` from it instead of running
them again (the chains are deterministic; only the official score's run-time gate depends on
the machine's load): a new model is then compared with the earlier backends' numbers.

The same chain runs on the 10 CULane night frames and on the held-out CULane day clip (driver
161, 60 frames; the driver-23 clip is the one trained on): another, unknown camera, estimated
from each set's frames without their labels (``pipelines/culane_night.py``), scored with ``slt
eval culane`` (F1 at IoU 0.5); every ONNX model is scored on CamVid ``val`` (level-1 / level-2
mIoU).

``--update-cards`` writes each ONNX model's numbers on every real set (and the classical
backend's from the same run) into its model card, where ``--backend auto`` reads them.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pyarrow.parquet as pq

from superlane_tools.camera import load_camera
from superlane_tools.evaluation import evaluate, evaluate_frames, load_jsonl
from superlane_tools.evaluation.kitti import decode_ground_truth, lane_area_mask, score_mask
from superlane_tools.hierarchy import leaf_ids_under
from superlane_tools.lanes.project import columns_at_rows
from superlane_tools.lanes.table import lanes_from_row
from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.reporting.layout import TUSIMPLE_LABELS_FILE

sys.path.insert(0, str(Path(__file__).resolve().parent))
from culane_night import DAY_DEV_FOLDER, culane_chain, estimate_camera
from real_frames_overlays import kitti_overlay, overlay_sheet

REPO = Path(__file__).resolve().parents[1]
SLT = str(Path(sys.executable).with_name("slt"))
MARKING_IDS = np.array(leaf_ids_under("lane_marking"))
KITTI_NAME = "um_000000"


def _default_data() -> Path:
    return Path(os.environ.get("SLT_REALDATA", REPO.parent / "shared" / "data"))


def slt(*args: str | Path) -> tuple[str, str]:
    """Run one ``slt`` command; return it (for the report) and its stdout.

    Every command here writes an output; ``--overwrite`` replaces the previous run's.
    """
    args = (*args, "--overwrite")
    argv = [SLT, *map(str, args)]
    proc = subprocess.run(argv, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{shlex.join(argv)} failed ({proc.returncode}): {proc.stderr.strip()}")
    return shlex.join(["slt", *map(str, args)]), proc.stdout


def link_frames(sources: list[Path], folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for src in sources:
        link = folder / src.name
        if not link.exists():
            link.symlink_to(src.resolve())
    return folder


def validation_frames(data: Path, work: Path) -> tuple[list[tuple[Path, str]], Path, list[Path]]:
    """Write the fixed real validation split as PNGs with one ``labels.json``.

    The split: the last ``TUSIMPLE_VAL_FRAMES`` (30) frames of ``tusimple/train_frames`` (never
    trained on; named ``val_NNNN.png``) and the 6 labelled frames of ``tusimple/frames``. Frames
    go into one folder per ``h_samples`` range (the export must use the labels' rows).
    Returns ``[(folder, "START:STOP:STEP")]``, the labels file and the frame paths.
    """
    from superlane_tools.training.datasets import (
        TUSIMPLE_VAL_FRAMES,
        _split_rows,
        tusimple_labels,
    )

    lines: list[dict[str, Any]] = []
    groups: dict[str, Path] = {}
    paths: list[Path] = []

    def add(label: dict[str, Any], source: Path, name: str) -> None:
        rows = label["h_samples"]
        key = f"{rows[0]}:{rows[-1] + rows[1] - rows[0]}:{rows[1] - rows[0]}"
        folder = groups.setdefault(key, work / f"val_frames_{rows[0]}")
        folder.mkdir(parents=True, exist_ok=True)
        if not (folder / name).is_file():
            cv2.imwrite(str(folder / name), cv2.imread(str(source)))
        lines.append({**label, "raw_file": name})
        paths.append(folder / name)

    train_frames = data / "tusimple" / "train_frames"
    labels = tusimple_labels(train_frames)
    for label in labels[_split_rows(len(labels), "val", TUSIMPLE_VAL_FRAMES)]:
        name = f"val_{Path(label['raw_file']).stem}.png"
        add(label, train_frames / label["raw_file"], name)
    frames_src = data / "tusimple" / "frames"
    for label in tusimple_labels(frames_src):
        add(label, frames_src / label["raw_file"], str(label["raw_file"]))
    labels_path = work / "val_labels.json"
    labels_path.write_text("".join(json.dumps(x) + "\n" for x in lines), encoding="utf-8")
    return [(folder, key) for key, folder in groups.items()], labels_path, paths


def marking_support(seg_dir: Path, labels_json: Path) -> tuple[float, float]:
    """Return (recall within 3 px, precision within 10 px) of marking pixels vs the labels."""
    found = total = near = marked = 0
    for rec in load_jsonl(labels_json):
        found_path = next(seg_dir.rglob(rec.raw_file))
        mask = np.isin(cv2.imread(str(found_path), cv2.IMREAD_UNCHANGED), MARKING_IDS)
        gt = np.zeros(mask.shape, dtype=np.uint8)
        for lane in rec.lanes:
            pts = [(x, y) for x, y in zip(lane, rec.h_samples, strict=True) if x >= 0]
            for x, y in pts:
                total += 1
                y0, x0 = int(y), round(x)
                found += bool(mask[max(y0 - 3, 0) : y0 + 4, max(x0 - 3, 0) : x0 + 4].any())
            poly = np.array(pts, dtype=np.float64).round().astype(np.int32)
            if len(poly) > 1:
                cv2.polylines(gt, [poly], False, 1, thickness=21)
        near += int(np.count_nonzero(mask & (gt > 0)))
        marked += int(np.count_nonzero(mask))
    return found / max(total, 1), near / max(marked, 1)


CANONICAL = "@canonical"
"""Suffix of ``onnx=MODEL@canonical``: the model run in the canonical camera (``slt segment
--canonical-camera``), for a model trained without it (with and without, on every set)."""


def backend_args(spec: str) -> tuple[str, list[str]]:
    """Return (label, ``slt segment`` options) of ``classical``, ``onnx`` or ``onnx=MODEL``.

    ``onnx=MODEL@canonical`` runs the model in the canonical camera (label ``..._canonical``).
    """
    name, _, model = spec.partition("=")
    if not model:
        return name, ["--backend", name]
    model, canonical = model.removesuffix(CANONICAL), model.endswith(CANONICAL)
    label = f"{name}_{Path(model).name.removesuffix('.onnx')}" + ("_canonical" if canonical else "")
    return label, [
        "--backend",
        name,
        "--model",
        model,
        *(["--canonical-camera"] if canonical else []),
    ]


def tusimple_chain(
    spec: str, groups: list[tuple[Path, str]], labels: Path, work: Path
) -> dict[str, Any]:
    """Run the four-command chain for one backend; return scores, commands and timings.

    Segment, fit and export run per frame folder (each with its labels' ``h_samples``); the
    exported predictions are concatenated and scored by one ``slt eval tusimple``.
    """
    backend, options = backend_args(spec)
    seg = work / f"seg_{backend}"
    pred = work / f"pred_{backend}.json"
    t0 = time.perf_counter()
    commands = []
    parts = []
    for folder, rows in groups:
        seg_part = seg / folder.name
        lanes = work / f"lanes_{backend}_{folder.name}.parquet"
        part = work / f"pred_{backend}_{folder.name}.json"
        commands += [
            slt("segment", folder, "--out", seg_part, *options, "--camera", "tusimple",
                "--overlay")[0],
            slt("lanes", "fit", seg_part, "--camera", "tusimple", "--out", lanes)[0],
            slt("lanes", "export-tusimple", lanes, "--camera", "tusimple", "--h-samples", rows,
                "--out", part, "--raw-ext", ".png")[0],
        ]  # fmt: skip
        parts.append(part.read_text(encoding="utf-8"))
    pred.write_text("".join(parts), encoding="utf-8")
    commands.append(f"cat WORK/pred_{backend}_*.json > {pred}")
    cmd, out = slt("eval", "tusimple", pred, labels, "--json")
    commands.append(cmd)
    official = json.loads(out)
    preds, gts = load_jsonl(pred), load_jsonl(labels)
    no_gate = [p._replace(run_time_ms=0.0) for p in preds]
    ungated = evaluate(no_gate, gts)
    recall, precision = marking_support(seg, labels)
    return {
        "official": official,
        "ungated": dataclasses.asdict(ungated),
        "frames": [s._asdict() for s in evaluate_frames(no_gate, gts)],
        "run_time_ms": [p.run_time_ms for p in preds],
        "marking_recall_3px": recall,
        "marking_precision_10px": precision,
        "commands": commands,
        "wall_s": time.perf_counter() - t0,
        "seg": str(seg),
        "pred": str(pred),
    }


def kitti_chain(spec: str, data: Path, work: Path) -> dict[str, Any]:
    """Segment and fit KITTI ``um_000000``; score the fitted ego lane against the lane GT."""
    backend, options = backend_args(spec)
    folder = link_frames([data / "kitti_road" / f"image_{KITTI_NAME}.png"], work / "kitti_frames")
    seg, lanes = work / f"kitti_seg_{backend}", work / f"kitti_lanes_{backend}.parquet"
    commands = [
        slt("segment", folder, "--out", seg, *options, "--camera", "kitti", "--overlay")[0],
        slt("lanes", "fit", seg, "--camera", "kitti", "--out", lanes)[0],
    ]  # fmt: skip
    row = pq.read_table(lanes).to_pylist()[0]
    gt_bgr = cv2.imread(str(data / "kitti_road" / f"gt_um_lane_{KITTI_NAME[3:]}.png"))
    gt = decode_ground_truth(gt_bgr[:, :, ::-1])
    camera = load_camera("kitti").resized(int(row["width"]), int(row["height"]))
    pred = ego_lane_mask(row, camera, gt.positive.shape)
    score = score_mask(pred, gt)
    return {
        "score": score._asdict(),
        "lane_width_m": row["lane_width"],
        "reason": row["reason"],
        "commands": commands,
        "seg": str(seg),
        "mask": pred,
    }


def ego_lane_mask(row: dict[str, Any], camera: Any, shape: tuple[int, int]) -> np.ndarray:
    """Rasterise the area between the fitted ego lines of a ``lanes.parquet`` row."""
    lanes, slope = lanes_from_row(row)
    ego = [-1 if row[key] is None else int(row[key]) for key in ("ego_left", "ego_right")]
    if not lanes or min(ego) < 0:
        return np.zeros(shape, dtype=bool)
    left, right = lanes[ego[0]], lanes[ego[1]]
    rows = np.arange(shape[0])
    cols_l = columns_at_rows(left, slope, camera, rows.astype(np.float64))
    cols_r = columns_at_rows(right, slope, camera, rows.astype(np.float64))
    return lane_area_mask(cols_l, cols_r, rows, shape)


def unlabeled_chain(spec: str, data: Path, work: Path) -> Path:
    """Segment, fit and export the unlabelled TuSimple frames (for overlays only)."""
    backend, options = backend_args(spec)
    src = data / "tusimple" / "frames" / "unlabeled"
    seg, lanes = work / f"unl_seg_{backend}", work / f"unl_lanes_{backend}.parquet"
    pred = work / f"unl_pred_{backend}.json"
    slt("segment", src, "--out", seg, *options, "--camera", "tusimple")
    slt("lanes", "fit", seg, "--camera", "tusimple", "--out", lanes)
    slt("lanes", "export-tusimple", lanes, "--camera", "tusimple", "--h-samples", "160:720:10",
        "--out", pred, "--raw-ext", ".jpg")  # fmt: skip
    return pred


NOTES = """\
## How to read this

* **LaneEval acc / FP / FN / F1**: the official TuSimple metric (`slt eval tusimple`). It scores
  a frame 0 when its `run_time` exceeds 200 ms; `run_time` is the lane fit's time per frame
  (loading the compiled kernels is set-up, not fit time). "acc without run-time gate" re-scores
  the same predictions with `run_time = 0`: the accuracy of the geometry alone.
* **marking recall 3 px / precision 10 px**: labelled lane points with a predicted marking pixel
  in their 7x7 box; predicted marking pixels within 10 px of a labelled polyline.
* **KITTI ego IoU, F / P / R**: `superlane_tools.evaluation.kitti` on `gt_um_lane_000000.png`
  (magenta = ego lane, black not evaluated), perspective image. The predicted ego lane is the
  area between the fitted ego-left and ego-right lines, rasterised between the rows where both
  lines are inside their fitted ranges.
* Overlays: `--overlays DIR` writes `real_frames_<backend>.png` (labelled frames: marking pixels
  magenta, labels green, exported lanes red), `real_frames_unlabeled_<backend>.png` and
  `real_frames_kitti_<backend>.png` (GT ego lane green, fitted ego lane red). They are not
  committed (about 1 MB each).
"""


def render_report(results: dict[str, Any], data: Path, work: Path, backends: str) -> str:
    """Return the Markdown report (paths shown as ``DATA/`` and ``WORK/``)."""
    lines = [
        "# Real frames: end-to-end lane accuracy",
        "",
        f"Generated by `python pipelines/real_frames_eval.py --backends {backends} --report "
        "reports/real_frames.md`",
        "(numbers below are from that run). Real validation split, never trained on: the last",
        "30 frames of TuSimple `train_frames/` (`val_NNNN.png`) and the 6 labelled frames of",
        "`frames/` (`000N.png`), 36 frames; KITTI `um_000000`; CULane night (10 frames) and the",
        f"held-out CULane day clip `{DAY_DEV_FOLDER}` (60 frames). DATA = the real-data folder,",
        "WORK = the work folder.",
        "",
        "| backend | LaneEval acc | FP | FN | F1 | acc without run-time gate | marking recall 3 px"
        " | marking precision 10 px | KITTI ego IoU | KITTI F / P / R | CULane night F1@50"
        " | CULane day (held-out clip) F1@50 | CamVid val mIoU L1 / L2 |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, res in results.items():
        off, ung, k = res["tusimple"]["official"], res["tusimple"]["ungated"], res["kitti"]["score"]
        t = res["tusimple"]
        camvid = res.get("camvid")
        lines.append(
            f"| {name} | {off['accuracy']:.3f} | {off['fp']:.3f} | {off['fn']:.3f} "
            f"| {off['f1']:.3f} | {ung['accuracy']:.3f} | {t['marking_recall_3px']:.3f} "
            f"| {t['marking_precision_10px']:.3f} | {k['iou']:.3f} "
            f"| {k['f_measure']:.3f} / {k['precision']:.3f} / {k['recall']:.3f} "
            f"| {culane_f1(res):.3f} | "
            + (f"{culane_f1(res, 'culane_day'):.3f} | " if "culane_day" in res else "- | ")
            + ("- |" if camvid is None else f"{camvid['miou_l1']:.3f} / {camvid['miou_l2']:.3f} |")
        )
    lines += ["", "## Per frame (run-time gate off) and fit run times", ""]
    for name, res in results.items():
        t = res["tusimple"]
        cells = [
            f"{f['raw_file']} {f['accuracy']:.3f} (FP {f['fp']:.2f}, FN {f['fn']:.2f}, {rt:.0f} ms)"
            for f, rt in zip(t["frames"], t["run_time_ms"], strict=True)
        ]
        lines.append(f"* **{name}**: " + "; ".join(cells))
    lines += ["", "## Exact commands", ""]
    for name, res in results.items():
        lines += [f"{name}:", "", "```"]
        lines += res["tusimple"]["commands"] + res["kitti"]["commands"]
        lines += res["culane"]["commands"] + res.get("culane_day", {}).get("commands", [])
        lines += ["```", ""]
    lines += ["", NOTES]
    text = "\n".join(lines)
    return text.replace(f"{work}/", "WORK/").replace(f"{data}/", "DATA/")


SPLIT_TEXT = (
    "last 30 frames of tusimple/train_frames (never trained on) + the 6 frames of tusimple/frames"
)
CHAIN_TEXT = (
    "python pipelines/real_frames_eval.py (slt segment -> slt lanes fit --camera tusimple -> "
    "slt lanes export-tusimple -> slt eval tusimple)"
)


def culane_f1(result: dict[str, Any], key: str = "culane") -> float:
    """Return a backend's CULane F1 at IoU 0.5: night (``culane``) or day (``culane_day``)."""
    scores = result[key]["score"]  # {"all": {"f1_50": ...}}: one set, all its frames
    return float(next(iter(scores.values()))["f1_50"])


def real_sets(result: dict[str, Any], classical: dict[str, Any]) -> dict[str, Any]:
    """Return the per-real-set scores that ``auto`` compares (``scene/backends.py``).

    Each lane set gives the model's score and the classical backend's from the same run: TuSimple
    dev end to end (LaneEval accuracy without the 200 ms run-time gate: on a loaded machine the
    gate scores the fit's wall time, not the lanes), KITTI ``um_000000`` fitted ego lane (F),
    CULane night and the held-out CULane day clip (F1@50). CamVid val (level-2 mIoU) has no
    classical number (the classical backend finds markings only).
    """
    sets = {
        "tusimple_dev_laneeval": (
            result["tusimple"]["ungated"]["accuracy"],
            classical["tusimple"]["ungated"]["accuracy"],
        ),
        "kitti_um_000000_f": (
            result["kitti"]["score"]["f_measure"],
            classical["kitti"]["score"]["f_measure"],
        ),
    }
    for key, name in (("culane", "culane_night_f1"), ("culane_day", "culane_day_f1")):
        if key in result and key in classical:
            sets[name] = (culane_f1(result, key), culane_f1(classical, key))
    out: dict[str, Any] = {
        name: {"model": round(float(m), 4), "classical": round(float(c), 4)}
        for name, (m, c) in sets.items()
    }
    if result.get("camvid") is not None:
        out["camvid_val_miou_l2"] = {"model": round(float(result["camvid"]["miou_l2"]), 4)}
    return out


def card_metrics(result: dict[str, Any], classical: dict[str, Any]) -> dict[str, Any]:
    """Return one ONNX backend's end-to-end card metrics, with the classical backend's beside.

    ``auto`` (``scene/backends.py``) compares the worst of ``real_sets`` with the classical
    backend's worst: both must come from the same run of the same code.
    """
    tus, cls = result["tusimple"], classical["tusimple"]["official"]
    off, kit = tus["official"], result["kitti"]["score"]
    return {
        "real_sets": real_sets(result, classical),
        "tusimple_val_end_to_end": {
            "laneeval_accuracy": round(off["accuracy"], 4),
            "fp": round(off["fp"], 4),
            "fn": round(off["fn"], 4),
            "f1": round(off["f1"], 4),
            "frames": len(tus["frames"]),
            "accuracy_without_run_time_gate": round(tus["ungated"]["accuracy"], 4),
            "marking_recall_3px": round(tus["marking_recall_3px"], 4),
            "marking_precision_10px": round(tus["marking_precision_10px"], 4),
            "classical_laneeval_accuracy": round(cls["accuracy"], 4),
            "classical_fp": round(cls["fp"], 4),
            "classical_fn": round(cls["fn"], 4),
            "split": SPLIT_TEXT,
            "chain": CHAIN_TEXT,
        },
        "kitti_um_000000_fitted_ego_lane": {
            key: round(kit[key], 4) for key in ("f_measure", "precision", "recall", "iou")
        },
        **({"camvid_val": result["camvid"]} if result.get("camvid") is not None else {}),
        **(
            {
                "culane_night_end_to_end": {
                    "f1_iou50": round(culane_f1(result), 4),
                    "classical_f1_iou50": round(culane_f1(classical), 4),
                    "frames": 10,
                    "camera": "estimated from the frames, labels unused (culane_night.py)",
                }
            }
            if "culane" in result and "culane" in classical
            else {}
        ),
        **(
            {
                "culane_day_end_to_end": {
                    "f1_iou50": round(culane_f1(result, "culane_day"), 4),
                    "classical_f1_iou50": round(culane_f1(classical, "culane_day"), 4),
                    "frames": 60,
                    "clip": f"{DAY_DEV_FOLDER} (held out: the driver-23 clip is trained on)",
                    "camera": "estimated from the clip's frames, labels unused (culane_night.py)",
                }
            }
            if "culane_day" in result and "culane_day" in classical
            else {}
        ),
    }


def update_cards(results: dict[str, Any], specs: list[str]) -> list[str]:
    """Write each ONNX backend's end-to-end metrics into its model card; return the cards."""
    from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL, resolve_model
    from superlane_tools.training.evaluate import update_card

    written = []
    for spec in specs:
        name, _, model = spec.partition("=")
        if name != "onnx" or model.endswith(CANONICAL):  # a card holds the model as trained
            continue
        path = resolve_model(model or DEFAULT_SEGMENTATION_MODEL)[0]
        metrics = card_metrics(results[backend_args(spec)[0]], results["classical"])
        written.append(update_card(path, metrics, {}).name)
    return written


def camvid_val(spec: str, data: Path) -> dict[str, float]:
    """Return an ONNX backend's CamVid ``val`` level-1 / level-2 mIoU."""
    from superlane_tools.scene.onnx_backend import (
        DEFAULT_SEGMENTATION_MODEL,
        OnnxSegmentationBackend,
    )
    from superlane_tools.training.evaluate import camvid_scores

    model = spec.partition("=")[2] or DEFAULT_SEGMENTATION_MODEL
    scores = camvid_scores(OnnxSegmentationBackend(model, threads=1), data / "camvid", "val")
    return {"miou_l1": scores["miou_level1"], "miou_l2": scores["miou_level2"]}


def main(argv: list[str] | None = None) -> int:
    """Run the evaluation; write the report, overlays and optional JSON."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=_default_data())
    ap.add_argument("--work", type=Path, default=None, help="work folder (default: a temp dir)")
    ap.add_argument("--backends", default="classical,onnx")  # onnx=MODEL for a given model
    ap.add_argument("--report", type=Path, default=None, help="Markdown report to write")
    ap.add_argument("--overlays", type=Path, default=None, help="folder for overlay PNGs")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--update-cards",
        action="store_true",
        help="write each ONNX model's end-to-end metrics into its card (needs classical too)",
    )
    ap.add_argument(
        "--reuse",
        type=Path,
        default=None,
        help="--json of an earlier run: its backends are taken from it, not run again",
    )
    args = ap.parse_args(argv)
    specs = args.backends.split(",")
    if args.update_cards and "classical" not in specs:
        print("--update-cards needs the classical backend in --backends", file=sys.stderr)
        return 2
    frames_src = args.data / "tusimple" / "frames"
    if not (frames_src / TUSIMPLE_LABELS_FILE).is_file():
        print(f"no real data at {args.data}", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        groups, labels, frame_paths = validation_frames(args.data, work)
        culane_camera = estimate_camera(args.data, work / "culane_night.yaml")
        day_camera = estimate_camera(args.data, work / "culane_day.yaml", DAY_DEV_FOLDER)
        results: dict[str, Any] = {}
        if args.reuse is not None:
            # the chains are deterministic (only the official score's run-time gate depends on
            # the machine's load): an earlier run's backends need not run again
            results.update(json.loads(args.reuse.read_text(encoding="utf-8")))
        for spec in specs:
            backend, options = backend_args(spec)
            if backend in results:
                print(f"{backend}: reused from {args.reuse}", flush=True)
                continue
            tus = tusimple_chain(spec, groups, labels, work)
            kit = kitti_chain(spec, args.data, work)
            cul = culane_chain(options, backend, args.data, work, culane_camera, slt)
            day = culane_chain(options, backend, args.data, work, day_camera, slt,
                               DAY_DEV_FOLDER, "culane_day")  # fmt: skip
            results[backend] = {"tusimple": tus, "kitti": kit, "culane": cul, "culane_day": day}
            if spec.startswith("onnx") and not spec.endswith(CANONICAL):  # CamVid: camera unknown
                results[backend]["camvid"] = camvid_val(spec, args.data)
            off = tus["official"]
            print(
                f"{backend}: LaneEval acc {off['accuracy']:.4f} FP {off['fp']:.4f} "
                f"FN {off['fn']:.4f} (no run-time gate: {tus['ungated']['accuracy']:.4f}); "
                f"KITTI ego IoU {kit['score']['iou']:.4f} F {kit['score']['f_measure']:.4f}; "
                f"CULane night F1 {culane_f1(results[backend]):.4f}, "
                f"day {culane_f1(results[backend], 'culane_day'):.4f}; "
                f"CamVid {results[backend].get('camvid')}",
                flush=True,
            )
            if args.overlays is not None:
                args.overlays.mkdir(parents=True, exist_ok=True)
                overlay_sheet(
                    Path(tus["seg"]),
                    Path(tus["pred"]),
                    labels,
                    frame_paths[-12:],
                    args.overlays / f"real_frames_{backend}.png",
                )
                unl = unlabeled_chain(spec, args.data, work)
                overlay_sheet(
                    work / f"unl_seg_{backend}",
                    unl,
                    None,
                    sorted((frames_src / "unlabeled").glob("*.jpg")),
                    args.overlays / f"real_frames_unlabeled_{backend}.png",
                )
                kitti_overlay(args.data, kit, args.overlays / f"real_frames_kitti_{backend}.png")
            kit.pop("mask")
        if args.report is not None:
            write_text_atomic(args.report, render_report(results, args.data, work, args.backends))
        if args.update_cards:
            print(f"cards updated: {', '.join(update_cards(results, specs))}")
    if args.json is not None:
        write_text_atomic(args.json, json.dumps(results, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
