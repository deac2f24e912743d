"""`slt eval`: score lane predictions with the official benchmark metrics."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import cli_errors

eval_app = typer.Typer(
    name="eval",
    help="Score lane predictions against ground truth with the official benchmark metrics.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


@eval_app.command("tusimple")
def tusimple_cmd(
    pred: Annotated[Path, typer.Argument(help="Predictions, TuSimple JSON lines.")],
    gt: Annotated[Path, typer.Argument(help="Ground truth, TuSimple JSON lines (label file).")],
    as_json: Annotated[
        bool, typer.Option("--json", help="Print the score as one JSON object.")
    ] = False,
) -> None:
    """Print TuSimple accuracy, FP, FN and F1 (official LaneEval rules; see docs/camera.md)."""
    from superlane_tools.evaluation import evaluate, load_jsonl

    with cli_errors():
        preds = load_jsonl(pred, require_h_samples=False)
        gts = load_jsonl(gt, require_h_samples=True)
        score = evaluate(preds, gts)
    if as_json:
        typer.echo(json.dumps(score.as_dict()))
        return
    typer.echo(f"frames    {score.n_frames}")
    typer.echo(f"accuracy  {score.accuracy:.4f}")
    typer.echo(f"FP        {score.fp:.4f}")
    typer.echo(f"FN        {score.fn:.4f}")
    typer.echo(f"F1        {score.f1:.4f}")


def register(app: typer.Typer) -> None:
    """Add the ``eval`` command group to the root app."""
    app.add_typer(eval_app, name="eval")
