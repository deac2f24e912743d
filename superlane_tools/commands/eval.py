"""`slt eval`: score lane predictions with the benchmarks' metrics; optionally save a record.

Each benchmark has one entry (:func:`tusimple`, :func:`attributes`, :func:`kitti`,
:func:`culane`, :func:`caltech`) returning an :class:`EvalResult`; a record for
``slt tables paper`` is written when :class:`SaveRequest` names a file.
"""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from superlane_tools.commands.options import OutputGuard
from superlane_tools.errors import UsageError


@dataclass(frozen=True)
class SaveRequest:
    """Where to save the evaluation record (``--save``), and its place in the paper tables.

    Attributes:
        path: The record file, or None (no record).
        row: Paper-table row.
        column: Paper-table column.
        command: The command line, for the record.
        output_guard: Entered around the writing (the cli's policy for an existing output).
    """

    path: Path | None = None
    row: str = "SUPER"
    column: str = ""
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


@dataclass(frozen=True)
class EvalResult:
    """A benchmark's score.

    Attributes:
        metrics: What the record holds (JSON-ready).
        rows: Per-set or per-clip rows for the table (empty where ``metrics`` is flat).
        missing: Frames without a prediction (scored as empty).
        saved: The record written, or None.
    """

    metrics: dict[str, Any]
    rows: list[dict[str, Any]] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    saved: Path | None = None


def kitti_categories() -> tuple[str, ...]:
    """Return the KITTI road categories (``--category``)."""
    from superlane_tools.evaluation.kitti_files import CATEGORIES

    return tuple(CATEGORIES)


def caltech_clips() -> tuple[str, ...]:
    """Return the Caltech lanes clips (``--clip``)."""
    from superlane_tools.evaluation.caltech import CLIPS

    return tuple(CLIPS)


def _save(
    save: SaveRequest,
    kind: str,
    metrics: dict[str, Any],
    pred: Path,
    gt: Path,
    extra: dict[str, Any] | None = None,
) -> Path | None:
    if save.path is None:
        return None
    from superlane_tools.reporting.paper_tables import EvalRecord, file_ref, save_record

    record = EvalRecord(
        kind=kind,
        row=save.row,
        column=save.column,
        metrics=metrics,
        command=save.command,
        predictions=file_ref(pred),
        ground_truth=file_ref(gt),
        extra=extra or {},
    )
    with save.output_guard:
        return save_record(record, save.path)


def _check_mode(mode: str) -> None:
    from superlane_tools.evaluation import MODES

    if mode not in MODES:
        raise UsageError(f"--mode must be one of {', '.join(MODES)}, not {mode!r}")


def tusimple(
    pred: Path, gt: Path, mode: str, centre: float, time_gate: bool, save: SaveRequest
) -> EvalResult:
    """TuSimple accuracy, FP, FN and F1 (official LaneEval rules, or an ego ``mode``).

    ``rows`` holds one row: the score as the table prints it.
    """
    from superlane_tools.evaluation import evaluate, evaluate_mode, load_jsonl

    _check_mode(mode)
    preds = load_jsonl(pred, require_h_samples=False)
    if not time_gate:
        preds = [p._replace(run_time_ms=0.0) for p in preds]
    gts = load_jsonl(gt, require_h_samples=True)
    score = evaluate(preds, gts) if mode == "all" else evaluate_mode(preds, gts, mode, centre)
    extra = {"mode": mode, "time_gate": time_gate}
    saved = _save(save, "tusimple", score.as_dict(), pred, gt, extra)
    row = {
        "frames": score.n_frames,
        "accuracy": score.accuracy,
        "FP": score.fp,
        "FN": score.fn,
        "F1": score.f1,
    }
    return EvalResult(score.as_dict(), [row], saved=saved)


def attributes(pred: Path, gt: Path, mode: str, centre: float, save: SaveRequest) -> EvalResult:
    """Lane colour and style accuracy over the ground-truth lines a prediction found."""
    from superlane_tools.evaluation import attribute_accuracy, load_jsonl

    _check_mode(mode)
    acc = attribute_accuracy(
        load_jsonl(pred, require_h_samples=False),
        load_jsonl(gt, require_h_samples=True),
        mode,
        centre,
    )
    saved = _save(save, "attributes", acc.as_dict(), pred, gt, {"mode": mode})
    return EvalResult(acc.as_dict(), saved=saved)


def kitti(pred_dir: Path, kitti_root: Path, category: str, save: SaveRequest) -> EvalResult:
    """The KITTI road benchmark in the bird's-eye view: MaxF, AP, precision, recall, FPR."""
    from superlane_tools.evaluation.kitti_files import evaluate_folder

    run = evaluate_folder(pred_dir, kitti_root, category)
    values: dict[str, Any] = run.score.as_dict()
    saved = _save(save, "kitti", values, pred_dir, kitti_root, {"category": category})
    return EvalResult(values, missing=[str(m) for m in run.missing], saved=saved)


def culane(
    pred_dir: Path, gt_root: Path, lists: list[Path], size: tuple[int, int], save: SaveRequest
) -> EvalResult:
    """CULane F1 at IoU 0.5 per list, F1@75 and mF1; ``metrics["sets"]`` maps list -> row."""
    from superlane_tools.evaluation.culane import evaluate_folder

    run = evaluate_folder(pred_dir, gt_root, lists, size=size)
    sets = {
        r.name: {
            "frames": r.n_frames,
            "tp": r.at(0.5).tp,
            "fp": r.at(0.5).fp,
            "fn": r.at(0.5).fn,
            "precision_50": r.at(0.5).precision,
            "recall_50": r.at(0.5).recall,
            "f1_50": r.at(0.5).f1,
            "f1_75": r.at(0.75).f1,
            "mf1": r.mf1,
        }
        for r in run.results
    }
    saved = _save(save, "culane", {"sets": sets}, pred_dir, gt_root)
    return EvalResult({"sets": sets}, missing=[str(m) for m in run.missing], saved=saved)


def caltech(pred_dir: Path, caltech_root: Path, clips: list[str], save: SaveRequest) -> EvalResult:
    """Caltech lanes TPR per clip; ``rows`` holds each clip's score, then all clips'."""
    from superlane_tools.evaluation.caltech import CLIPS, evaluate_clip, total
    from superlane_tools.evaluation.errors import EvaluationError

    names = clips or [c for c in CLIPS if (caltech_root / c / "labels.ccvl").is_file()]
    if not names:
        raise EvaluationError(f"no <clip>/labels.ccvl under {caltech_root}")
    scores, missing = [], []
    for name in names:
        score, miss = evaluate_clip(pred_dir / name, caltech_root / name / "labels.ccvl", name)
        scores.append(score)
        missing += [f"{name}/{m}" for m in miss]
    clip_values = {s.name: asdict(s) for s in scores}
    saved = _save(save, "caltech", {"clips": clip_values}, pred_dir, caltech_root)
    rows = [asdict(s) for s in [*scores, total(scores)]]
    return EvalResult({"clips": clip_values}, rows, missing, saved)
