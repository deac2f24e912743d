"""Re-run the lane tracker on finished reprocess runs with other ``TrackerParams``; tabulate RMSE.

The tracker is the last step of the curvature chain and ``curvature.parquet`` keeps its inputs
(the per-frame fit ``super_fit_*``, ``super_curvature``, ``super_lookahead_m`` and the travelled
distance ``super_travelled_m``), so a parameter set is scored without re-running segmentation or
the lane fit: for each run the track is recomputed exactly as ``slt reprocess`` does it
(:func:`superlane_tools.lanes.track_lanes`, then road and lateral curvature each smoothed like
the RTK truth and summed) and the RMSE of ``super_path`` against ``rtk_curvature`` is computed
with the report's own :func:`~superlane_tools.evaluation.curvature.curvature_errors`. The
``current`` column recomputes the run's own parameters (``--run-params``, default today's)
and must match the run's ``curvature_summary.parquet`` (checked; a mismatch exits 1).

Drives used for issue 25 item 8 (none of them a test seed), each made with::

    slt simulate -s SCENARIO --seed SEED --duration 20 --width 640 --height 360 -o DRIVE.mcap
    slt reprocess DRIVE.mcap --config pipelines/reprocess_challenge.toml --no-plots -o RUNS/NAME

Usage:
    python pipelines/tune_tracker.py RUNS/NAME [RUNS/NAME ...] [--set manoeuvre_psd=1e-8 ...]
        [--run-params manoeuvre_psd=1e-7] [--markdown]

Each ``--set`` is one candidate (comma-separated ``field=value`` pairs of ``TrackerParams``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.drive.config import RtkConfig, TrackingConfig
from superlane_tools.evaluation.curvature import curvature_errors
from superlane_tools.lanes.lookahead import smooth_like_truth
from superlane_tools.lanes.tracker import COV_INDEX, COV_KEYS, TrackerParams, track_lanes
from superlane_tools.reporting.layout import CURVATURE_SUMMARY_TABLE, CURVATURE_TABLE


def path_rmse(curv: pd.DataFrame, params: TrackerParams, rtk: RtkConfig) -> float:
    """Return the ``super_path`` RMSE (1/m) of ``curv``'s fits tracked with ``params``."""
    n = len(curv)
    cov = np.full((n, 3, 3), np.nan)
    for key, (i, j) in zip(COV_KEYS, COV_INDEX, strict=True):
        cov[:, i, j] = cov[:, j, i] = curv[key].to_numpy(dtype=np.float64)
    track = track_lanes(
        curv["super_travelled_m"].to_numpy(dtype=np.float64),
        curv["super_fit_a1"].to_numpy(dtype=np.float64),
        curv["super_curvature"].to_numpy(dtype=np.float64),
        curv["super_fit_b"].to_numpy(dtype=np.float64),
        curv["super_fit_near_m"].to_numpy(dtype=np.float64),
        curv["super_fit_far_m"].to_numpy(dtype=np.float64),
        curv["super_fit_trackable"].to_numpy() > 0.5,
        params,
        cov,
        curv["super_lookahead_m"].to_numpy(dtype=np.float64),
    )
    s_rtk = curv["s_m"].to_numpy(dtype=np.float64)
    path = smooth_like_truth(s_rtk, track.road_per_m, rtk.window_m, rtk.ds_m) + smooth_like_truth(
        s_rtk, track.manoeuvre_per_m, rtk.window_m, rtk.ds_m
    )
    truth = curv["rtk_curvature"].to_numpy(dtype=np.float64)
    return float(curvature_errors(path, truth).rmse)


def _candidate(text: str) -> tuple[str, TrackerParams]:
    """Parse ``field=value,field=value`` into a labelled ``TrackerParams``."""
    fields = {f.name: f.type for f in dataclasses.fields(TrackerParams)}
    changes: dict[str, object] = {}
    for pair in text.split(","):
        key, _, value = pair.partition("=")
        if key not in fields:
            raise SystemExit(f"tune_tracker: unknown TrackerParams field {key!r}")
        changes[key] = int(value) if fields[key] in ("int", int) else float(value)
    return text, dataclasses.replace(TrackingConfig(), **changes)  # type: ignore[arg-type]


def main(argv: list[str] | None = None) -> int:
    """Print one row per run: the recomputed default and each candidate, RMSE in 1/m."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument(
        "--run-params",
        default="",
        help="The runs' TrackerParams where they differ from today's defaults (field=value,...).",
    )
    ap.add_argument("--markdown", action="store_true", help="Print a markdown table.")
    args = ap.parse_args(argv)
    run_params = _candidate(args.run_params)[1] if args.run_params else TrackingConfig()
    candidates = [("current", run_params), *(_candidate(s) for s in args.sets)]
    rtk = RtkConfig()
    rows = []
    for run in args.runs:
        curv = pd.read_parquet(run / CURVATURE_TABLE.file)
        table = pd.read_parquet(run / CURVATURE_SUMMARY_TABLE.file)
        pick = (table["scope"] == "overall") & (table["source"] == "super_path")
        reported = float(table.loc[pick, "rmse"].iloc[0])
        rmse = {label: path_rmse(curv, params, rtk) for label, params in candidates}
        if not np.isclose(rmse["current"], reported, rtol=1e-9, atol=0.0):
            print(
                f"tune_tracker: {run}: recomputed {rmse['current']} != run {reported}",
                file=sys.stderr,
            )
            return 1
        row: dict[str, object] = {"run": run.name, **rmse}
        rows.append(row)
    names = [str(r["run"]) for r in rows]
    base = np.array([float(r["current"]) for r in rows])  # type: ignore[arg-type]
    header = ["drive", "current"]
    cells = [[name, f"{v:.2e}"] for name, v in zip(names, base, strict=True)]
    notes = [f"current: mean {base.mean():.3e}"]
    for k, (label, _) in enumerate(candidates[1:], start=1):
        values = np.array([float(r[label]) for r in rows])  # type: ignore[arg-type]
        change = 100.0 * (values / base - 1.0)
        header.append(f"c{k}")
        for row_cells, v, d in zip(cells, values, change, strict=True):
            row_cells.append(f"{v:.2e} ({d:+.0f} %)")
        notes.append(
            f"c{k} = {label}: mean {values.mean():.3e}, lower on {int((change < 0).sum())} of "
            f"{len(change)}, change {change.min():+.0f} to {change.max():+.0f} %"
        )
    if args.markdown:
        print("| " + " | ".join(header) + " |")
        print("|---" * len(header) + "|")
        for row_cells in cells:
            print("| " + " | ".join(row_cells) + " |")
    else:
        print(pd.DataFrame(cells, columns=header).to_string(index=False))
    print("\n".join(notes))
    return 0


if __name__ == "__main__":
    sys.exit(main())
