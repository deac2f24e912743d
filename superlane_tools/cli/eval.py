"""`slt eval`: score lane predictions with the official benchmark metrics (docs/evaluation.md)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Annotated, Any

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    exit_with,
    note,
    report_skipped,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option
from superlane_tools.errors import ExitCode
from superlane_tools.records import Skipped

eval_app = typer.Typer(
    name="eval",
    help="Score lane predictions against ground truth with the official benchmark metrics."
    f"\n\n{EXIT_CODES_HELP}",
    no_args_is_help=True,
    rich_markup_mode=None,
)

AsJson = Annotated[bool, typer.Option("--json", help="Print the score as one JSON object.")]
Save = Annotated[
    Path | None,
    typer.Option(
        "--save",
        help="Also write an evaluation record (JSON: score, command, input hashes) for "
        "`slt tables paper`.",
    ),
]
Overwrite = Annotated[bool, overwrite_option()]
Row = Annotated[
    str,
    typer.Option(help="Paper-table row of the record (a method; Table 2: 'no sq' or 'sq')."),
]
Column = Annotated[
    str,
    typer.Option(
        help="Paper-table column of the record (Table 2: 'no sc' or 'sc'; Fig. 9: a subset)."
    ),
]


def _save(
    save: Path | None,
    kind: str,
    row: str,
    column: str,
    metrics: dict[str, Any],
    pred: Path,
    gt: Path,
    extra: dict[str, Any] | None = None,
    *,
    overwrite: bool = False,
) -> None:
    if save is None:
        return
    from superlane_tools.reporting.paper_tables import EvalRecord, file_ref, save_record

    record = EvalRecord(
        kind=kind,
        row=row,
        column=column,
        metrics=metrics,
        command=command_line(),
        predictions=file_ref(pred),
        ground_truth=file_ref(gt),
        extra=extra or {},
    )
    with new_output(save, overwrite, [pred, gt], replaces=True):
        note(f"wrote {save_record(record, save)}")


def _check_category(value: str) -> str:
    """Typer callback: a KITTI category that does not exist is a bad value (exit 2)."""
    from superlane_tools.evaluation.kitti_files import CATEGORIES

    if value not in CATEGORIES:
        raise typer.BadParameter(f"use one of {', '.join(CATEGORIES)}, not {value!r}")
    return value


def _check_clips(values: list[str] | None) -> list[str] | None:
    """Typer callback: a Caltech clip that does not exist is a bad value (exit 2)."""
    from superlane_tools.evaluation.caltech import CLIPS

    for value in values or []:
        if value not in CLIPS:
            raise typer.BadParameter(f"use one of {', '.join(CLIPS)}, not {value!r}")
    return values


def _report_missing(missing: Sequence[object]) -> ExitCode:
    """Report the frames without a prediction (scored as empty) as one skipped line."""
    first = f"first: {missing[0]}" if missing else ""
    lost = [Skipped("frames without a prediction, scored as empty", first, len(missing))]
    return report_skipped(lost if missing else [])


def _print(values: dict[str, Any], as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(values))
        return
    width = max(len(key) for key in values) + 2
    for key, value in values.items():
        text = f"{value:.4f}" if isinstance(value, float) else str(value)
        typer.echo(f"{key:<{width}}{text}")


@eval_app.command("tusimple")
def tusimple_cmd(
    pred: Annotated[Path, typer.Argument(help="Predictions, TuSimple JSON lines.")],
    gt: Annotated[Path, typer.Argument(help="Ground truth, TuSimple JSON lines (label file).")],
    as_json: AsJson = False,
    mode: Annotated[
        str,
        typer.Option(
            help="Lines scored: all (official), ego (ego lines), 3lane (ego lane and "
            "its neighbours)."
        ),
    ] = "all",
    centre: Annotated[
        float, typer.Option(help="Image column that separates left and right lines (ego modes).")
    ] = 640.0,
    no_time_gate: Annotated[
        bool,
        typer.Option(
            "--no-time-gate",
            help="Score every frame as if run_time were 0 (NOT official: the geometry alone, "
            "without LaneEval's 200 ms rule).",
        ),
    ] = False,
    save: Save = None,
    overwrite: Overwrite = False,
    row: Row = "no sq",
    column: Column = "sc",
) -> None:
    """Print TuSimple accuracy, FP, FN and F1 (official LaneEval rules, or an ego mode)."""
    from superlane_tools.errors import UsageError
    from superlane_tools.evaluation import MODES, evaluate, evaluate_mode, load_jsonl

    with cli_errors():
        check_new_output(save, overwrite)
        if mode not in MODES:
            raise UsageError(f"--mode must be one of {', '.join(MODES)}, not {mode!r}")
        preds = load_jsonl(pred, require_h_samples=False)
        if no_time_gate:
            preds = [p._replace(run_time_ms=0.0) for p in preds]
        gts = load_jsonl(gt, require_h_samples=True)
        score = evaluate(preds, gts) if mode == "all" else evaluate_mode(preds, gts, mode, centre)
        extra = {"mode": mode, "time_gate": not no_time_gate}
        _save(save, "tusimple", row, column, score.as_dict(), pred, gt, extra, overwrite=overwrite)
    values = score.as_dict()
    if not as_json:
        values = {
            "frames": score.n_frames,
            "accuracy": score.accuracy,
            "FP": score.fp,
            "FN": score.fn,
            "F1": score.f1,
        }
    _print(values, as_json)


@eval_app.command("attributes")
def attributes_cmd(
    pred: Annotated[
        Path, typer.Argument(help="Predictions, TuSimple JSON lines with color/style.")
    ],
    gt: Annotated[Path, typer.Argument(help="Ground truth, TuSimple JSON lines with color/style.")],
    as_json: AsJson = False,
    mode: Annotated[str, typer.Option(help="Lines counted: all, ego or 3lane.")] = "all",
    centre: Annotated[
        float, typer.Option(help="Image column that separates left and right lines.")
    ] = 640.0,
    save: Save = None,
    overwrite: Overwrite = False,
    row: Row = "SUPER",
    column: Column = "",
) -> None:
    """Print lane colour and style accuracy over the ground-truth lines found by a prediction."""
    from superlane_tools.errors import UsageError
    from superlane_tools.evaluation import MODES, attribute_accuracy, load_jsonl

    with cli_errors():
        check_new_output(save, overwrite)
        if mode not in MODES:
            raise UsageError(f"--mode must be one of {', '.join(MODES)}, not {mode!r}")
        acc = attribute_accuracy(
            load_jsonl(pred, require_h_samples=False),
            load_jsonl(gt, require_h_samples=True),
            mode,
            centre,
        )
        _save(
            save,
            "attributes",
            row,
            column,
            acc.as_dict(),
            pred,
            gt,
            {"mode": mode},
            overwrite=overwrite,
        )
    _print(acc.as_dict(), as_json)


@eval_app.command("kitti")
def kitti_cmd(
    pred_dir: Annotated[
        Path,
        typer.Argument(help="Folder of perspective confidence PNGs (um_lane_000000.png, 0-255)."),
    ],
    kitti_root: Annotated[
        Path, typer.Argument(help="KITTI road folder (training/gt_image_2 + calib, or flat).")
    ],
    category: Annotated[
        str,
        typer.Option(help="um_lane, um_road, umm_road or uu_road.", callback=_check_category),
    ] = "um_lane",
    as_json: AsJson = False,
    save: Save = None,
    overwrite: Overwrite = False,
    row: Row = "SUPER",
) -> None:
    """Print the KITTI road benchmark in the bird's-eye view: MaxF, AP, precision, recall, FPR."""
    from superlane_tools.evaluation.kitti_files import evaluate_folder

    with cli_errors():
        check_new_output(save, overwrite)
        run = evaluate_folder(pred_dir, kitti_root, category)
        values: dict[str, Any] = run.score.as_dict()
        _save(
            save,
            "kitti",
            row,
            "",
            values,
            pred_dir,
            kitti_root,
            {"category": category},
            overwrite=overwrite,
        )
    _print(values, as_json)
    exit_with(_report_missing(run.missing))


@eval_app.command("culane")
def culane_cmd(
    pred_dir: Annotated[Path, typer.Argument(help="Folder of predicted .lines.txt files.")],
    gt_root: Annotated[Path, typer.Argument(help="CULane root with the .lines.txt labels.")],
    lists: Annotated[
        list[Path] | None,
        typer.Option("--list", help="Frame list (one per scenario, e.g. test0_normal.txt)."),
    ] = None,
    width: Annotated[int, typer.Option(help="Image width, pixels.")] = 1640,
    height: Annotated[int, typer.Option(help="Image height, pixels.")] = 590,
    as_json: AsJson = False,
    save: Save = None,
    overwrite: Overwrite = False,
    row: Row = "SUPER",
) -> None:
    """Print CULane F1 at IoU 0.5 per list, F1@75 and mF1 (official 30 px lanes, Hungarian)."""
    from superlane_tools.evaluation.culane import evaluate_folder

    with cli_errors():
        check_new_output(save, overwrite)
        run = evaluate_folder(pred_dir, gt_root, lists or [], size=(width, height))
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
        _save(save, "culane", row, "", {"sets": sets}, pred_dir, gt_root, overwrite=overwrite)
    if as_json:
        typer.echo(json.dumps(sets))
    else:
        typer.echo(
            f"{'set':<20}{'frames':>7}{'P@50':>8}{'R@50':>8}{'F1@50':>8}{'F1@75':>8}{'mF1':>8}"
        )
        for name, s in sets.items():
            typer.echo(
                f"{name:<20}{s['frames']:>7}{s['precision_50']:>8.4f}{s['recall_50']:>8.4f}"
                f"{s['f1_50']:>8.4f}{s['f1_75']:>8.4f}{s['mf1']:>8.4f}"
            )
    exit_with(_report_missing(run.missing))


@eval_app.command("caltech")
def caltech_cmd(
    pred_dir: Annotated[
        Path, typer.Argument(help="Predictions: PRED_DIR/<clip>/<frame>.lines.txt.")
    ],
    caltech_root: Annotated[
        Path, typer.Argument(help="Caltech Lanes root: <clip>/labels.ccvl for each clip.")
    ],
    clips: Annotated[
        list[str] | None,
        typer.Option(
            "--clip", help="Clip to score (default: all four found).", callback=_check_clips
        ),
    ] = None,
    as_json: AsJson = False,
    save: Save = None,
    overwrite: Overwrite = False,
    row: Row = "SUPER",
) -> None:
    """Print Caltech lanes TPR per clip (Aly 2008 matching: mean <= 15 px or median <= 20 px)."""
    from superlane_tools.evaluation.caltech import CLIPS, evaluate_clip, total
    from superlane_tools.evaluation.errors import EvaluationError

    with cli_errors():
        check_new_output(save, overwrite)
        names = clips or [c for c in CLIPS if (caltech_root / c / "labels.ccvl").is_file()]
        if not names:
            raise EvaluationError(f"no <clip>/labels.ccvl under {caltech_root}")
        scores, missing = [], []
        for name in names:
            score, miss = evaluate_clip(pred_dir / name, caltech_root / name / "labels.ccvl", name)
            scores.append(score)
            missing += [f"{name}/{m}" for m in miss]
        clip_values = {s.name: asdict(s) for s in scores}
        _save(
            save,
            "caltech",
            row,
            "",
            {"clips": clip_values},
            pred_dir,
            caltech_root,
            overwrite=overwrite,
        )
    all_score = total(scores)
    if as_json:
        typer.echo(json.dumps({"clips": clip_values, "all": asdict(all_score)}))
    else:
        typer.echo(
            f"{'clip':<14}{'frames':>7}{'truth':>7}{'correct':>8}{'false':>7}{'TPR':>8}{'FP/frame':>9}"
        )
        for s in [*scores, all_score]:
            typer.echo(
                f"{s.name:<14}{s.n_frames:>7}{s.n_truth:>7}{s.correct:>8}{s.false:>7}"
                f"{s.tpr:>8.4f}{s.fp_per_frame:>9.3f}"
            )
    exit_with(_report_missing(missing))


def register(app: typer.Typer) -> None:
    """Add the ``eval`` command group to the root app."""
    app.add_typer(eval_app, name="eval")
