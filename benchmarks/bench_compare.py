"""Benchmark ``slt compare`` on two batch roots of 200 drives each (reads Parquet, not recordings).

Run: ``python benchmarks/bench_compare.py [--drives 200] [--keep] [--runs DIR]``
(``--runs``: reuse the ``base/`` and ``candidate/`` run folders of a kept earlier work folder).

Builds the fleets cheaply: two simulated 10 s drives (320x180) are reprocessed twice each with
the oracle segmentation, the candidate seeing blank label images in a 3 s span (so the runs
really differ); then each root gets ``--drives`` recording folders, copies of those four run
folders, and a ``batch_status.parquet`` in ``slt batch``'s schema where every copy has its own
content hash (so each is a distinct drive and base and candidate copies pair up). Times
``compare_runs`` in-process (imports warm, median of ``--rounds``, with and without plots) and
the whole ``slt compare`` command in a fresh process once, wall and CPU time (on a shared,
loaded machine the wall time mostly waits for a core). Writes
``benchmarks/results/compare.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.commands.batch.status import COLUMNS
from superlane_tools.commands.compare import CompareParams, compare_runs
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import BATCH_STATUS_TABLE
from superlane_tools.reporting.run_folder import staged_run
from superlane_tools.simulation.drive import simulate_drive

SCENARIOS = (("highway_curves", 1), ("urban", 2))
BLIND = range(60, 105)


def _runs(work: Path) -> dict[str, list[Path]]:
    import cv2

    runs: dict[str, list[Path]] = {"base": [], "candidate": []}
    for scenario, seed in SCENARIOS:
        rec = work / f"{scenario}.mcap"
        simulate_drive(scenario, 10.0, seed, "mcap", 320, 180, True, rec)
        labels = work / f"{scenario}_labels" / "labels"
        blind = work / f"{scenario}_blind"
        shutil.copytree(labels, blind)
        for k in BLIND:
            path = blind / f"{k:06d}.png"
            cv2.imwrite(str(path), np.zeros_like(cv2.imread(str(path), cv2.IMREAD_UNCHANGED)))
        for name, folder in (("base", labels), ("candidate", blind)):
            cfg = ReprocessConfig().with_overrides(
                {
                    "segmentation.backend": "oracle",
                    "segmentation.oracle_labels": str(folder),
                    "output.plots": False,
                    "output.example_frames": 0,
                    "kpi.window_s": 2.0,
                }
            )
            out = work / name / scenario
            with staged_run(out) as stage:
                reprocess(rec, stage, cfg)
            runs[name].append(out)
    return runs


def _root(root: Path, runs: list[Path], n: int) -> None:
    rows = []
    for i in range(n):
        src = runs[i % len(runs)]
        rid = f"{src.name}_{i:03d}-{i:010x}"
        shutil.copytree(src, root / rid)
        row: dict[str, object] = dict.fromkeys(COLUMNS, "")
        row.update(
            recording_id=rid,
            recording=f"/fleet/{rid}.mcap",
            category="highway" if "highway" in src.name else "urban",
            content_hash=f"blake3:{i:064x}",
            status="ok",
            result="ok",
            attempts=1,
            size_bytes=0,
            mtime_ns=0,
            total_s=0.0,
            outputs=0,
            frames=150,
            finished_ns=0,
            start_s=np.nan,
            end_s=np.nan,
        )
        rows.append(row)
    status = pd.DataFrame(rows).astype(COLUMNS)
    write_table(status, root / BATCH_STATUS_TABLE.file, Provenance(command="bench_compare"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("--drives", type=int, default=200)
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--rounds", type=int, default=3, help="timed compare runs (median)")
    ap.add_argument("--runs", type=Path, help="work folder of an earlier run (reuse its runs)")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench_compare_"))
    try:
        t0 = time.perf_counter()
        if args.runs is not None:
            runs = {n: sorted((args.runs / n).iterdir()) for n in ("base", "candidate")}
        else:
            runs = _runs(work)
        build_runs_s = time.perf_counter() - t0
        for name in ("base", "candidate"):
            _root(work / f"root_{name}", runs[name], args.drives)
        base, cand = work / "root_base", work / "root_candidate"
        timings: dict[str, list[float]] = {"with_plots": [], "no_plots": []}
        cpu: dict[str, list[float]] = {"with_plots": [], "no_plots": []}
        result = None
        for _ in range(args.rounds):
            for key, plots in (("with_plots", True), ("no_plots", False)):
                t, c = time.perf_counter(), time.process_time()
                result = compare_runs(base, cand, work / f"out_{key}", CompareParams(plots=plots))
                timings[key].append(time.perf_counter() - t)
                cpu[key].append(time.process_time() - c)
        assert result is not None
        t = time.perf_counter()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.run(
            [
                sys.executable,
                "-c",
                "from superlane_tools.cli.app import main; main()",
                "compare",
                str(base),
                str(cand),
                "-o",
                str(work / "out_cli"),
            ],
            capture_output=True,
            text=True,
            check=False,
        )
        cli_s = time.perf_counter() - t
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cli_cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        fleet = result.comparison.fleet_rows().set_index("kpi")
        out = {
            "command": f"python benchmarks/bench_compare.py --drives {args.drives} "
            f"--rounds {args.rounds}",
            "data": "simulated drives (2 x 10 s, 320x180, oracle segmentation), run folders "
            "copied into two batch roots",
            "drives_per_root": args.drives,
            "matched_drives": len(result.comparison.matched),
            "sequences_per_drive": int(
                result.comparison.table.query("scope == 'sequence' and kpi == 'fit_cost'")
                .groupby("drive")
                .size()
                .median()
            ),
            "compare_rows": len(result.comparison.table),
            "build_runs_s": round(build_runs_s, 1),
            "compare_in_process_s_median": round(statistics.median(timings["with_plots"]), 2),
            "compare_in_process_no_plots_s_median": round(
                statistics.median(timings["no_plots"]), 2
            ),
            "compare_in_process_s_all": [round(v, 2) for v in timings["with_plots"]],
            "compare_in_process_cpu_s_median": round(statistics.median(cpu["with_plots"]), 2),
            "compare_in_process_no_plots_cpu_s_median": round(
                statistics.median(cpu["no_plots"]), 2
            ),
            "slt_compare_fresh_process_cpu_s": round(cli_cpu, 2),
            "slt_compare_fresh_process_s": round(cli_s, 2),
            "slt_compare_exit_code": proc.returncode,
            "fleet_verdict_availability_frames_super": fleet.at[
                "availability_frames.super", "verdict"
            ],
            "load_average_1min": round(os.getloadavg()[0], 1),
            "cpus": os.cpu_count(),
        }
        path = Path(__file__).parent / "results" / "compare.json"
        path.write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")
        print(json.dumps(out, indent=2))
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
