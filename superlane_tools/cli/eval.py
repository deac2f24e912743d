"""`slt eval`: score lane predictions with the official benchmark metrics (docs/evaluation.md)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

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

if TYPE_CHECKING:
    from superlane_tools.commands.eval import EvalResult, SaveRequest

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
    save: Path | None, overwrite: bool, inputs: list[Path], row: str, column: str = ""
) -> SaveRequest:
    """Return the command's save request: ``--save``, its table cell, the output policy."""
    from superlane_tools.commands.eval import SaveRequest

    guard = new_output(save, overwrite, inputs, replaces=True)
    return SaveRequest(save, row, column, command_line(), guard)


def _saved(result: EvalResult) -> EvalResult:
    if result.saved is not None:
        note(f"wrote {result.saved}")
    return result


def _check_category(value: str) -> str:
    """Typer callback: a KITTI category that does not exist is a bad value (exit 2)."""
    from superlane_tools.commands.eval import kitti_categories

    categories = kitti_categories()
    if value not in categories:
        raise typer.BadParameter(f"use one of {', '.join(categories)}, not {value!r}")
    return value


def _check_clips(values: list[str] | None) -> list[str] | None:
    """Typer callback: a Caltech clip that does not exist is a bad value (exit 2)."""
    from superlane_tools.commands.eval import caltech_clips

    clips = caltech_clips()
    for value in values or []:
        if value not in clips:
            raise typer.BadParameter(f"use one of {', '.join(clips)}, not {value!r}")
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
    from superlane_tools.commands.eval import tusimple

    with cli_errors():
        check_new_output(save, overwrite)
        request = _save(save, overwrite, [pred, gt], row, column)
        result = _saved(tusimple(pred, gt, mode, centre, not no_time_gate, request))
    _print(result.metrics if as_json else result.rows[0], as_json)


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
    from superlane_tools.commands.eval import attributes

    with cli_errors():
        check_new_output(save, overwrite)
        request = _save(save, overwrite, [pred, gt], row, column)
        result = _saved(attributes(pred, gt, mode, centre, request))
    _print(result.metrics, as_json)


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
    from superlane_tools.commands.eval import kitti

    with cli_errors():
        check_new_output(save, overwrite)
        request = _save(save, overwrite, [pred_dir, kitti_root], row)
        result = _saved(kitti(pred_dir, kitti_root, category, request))
    _print(result.metrics, as_json)
    exit_with(_report_missing(result.missing))


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
    from superlane_tools.commands.eval import culane

    with cli_errors():
        check_new_output(save, overwrite)
        request = _save(save, overwrite, [pred_dir, gt_root], row)
        result = _saved(culane(pred_dir, gt_root, lists or [], (width, height), request))
    sets = result.metrics["sets"]
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
    exit_with(_report_missing(result.missing))


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
    from superlane_tools.commands.eval import caltech

    with cli_errors():
        check_new_output(save, overwrite)
        request = _save(save, overwrite, [pred_dir, caltech_root], row)
        result = _saved(caltech(pred_dir, caltech_root, clips or [], request))
    if as_json:
        typer.echo(json.dumps({"clips": result.metrics["clips"], "all": result.rows[-1]}))
    else:
        typer.echo(
            f"{'clip':<14}{'frames':>7}{'truth':>7}{'correct':>8}{'false':>7}{'TPR':>8}{'FP/frame':>9}"
        )
        for s in result.rows:
            typer.echo(
                f"{s['name']:<14}{s['n_frames']:>7}{s['n_truth']:>7}{s['correct']:>8}"
                f"{s['false']:>7}{s['tpr']:>8.4f}{s['fp_per_frame']:>9.3f}"
            )
    exit_with(_report_missing(result.missing))


def register(app: typer.Typer) -> None:
    """Add the ``eval`` command group to the root app."""
    app.add_typer(eval_app, name="eval")
