"""Benchmark what the segmentation self-check adds to a drive: ``auto`` against its own pick.

Usage::

    python benchmarks/bench_selfcheck.py [--recording PATH] [--repeats R] [--out FILE.json]

Runs ``reprocess`` on the recording (default: the README's demo drive,
``fixtures/sample_drive.mcap``) once untimed (kernels, page cache), reads which backend the
self-check chose, then times ``R`` pairs, alternating:

* baseline: ``reprocess`` with that backend and model given explicitly (no self-check);
* auto: ``reprocess`` with the default ``auto`` backend (the self-check, then the same pass).

The self-check's cost to the drive is the difference of the two runs' process CPU time (all
threads), per pair; that difference is as noisy as a whole run's CPU (on 2 busy cores, +-1 s
from run to run), so the JSON also holds a steadier bound: the check's own CPU less the
segmentation CPU the pass saved (the explicit run's segmentation thread CPU, the frames table,
on the frames the auto run took from the sample: those it segmented in under 1 ms), an upper
bound since the ONNX session it also saved is not counted. The JSON holds the medians, the
self-check's own CPU (``cpu_s`` in the provenance: what it spent, before the pass reused its
sample), the whole runs' CPU and their ratio, and whether the two runs' tables are the same
(the reuse must change no result; ``pipelines/compare_runs.py``, cell by cell). CPU time
depends on the load far less than wall time; the load is recorded.
Writes ``benchmarks/results/selfcheck.json`` (``--out``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

from _machine import uptime, write_results

REPO = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results" / "selfcheck.json"


def _check(run: Path) -> dict[str, Any]:
    from superlane_tools.reporting import read_provenance
    from superlane_tools.reporting.layout import RunLayout

    check = read_provenance(RunLayout(run).frames)["config"]["resolved"]["segmentation_self_check"]
    return check if isinstance(check, dict) else {}


def _saved_segmentation_s(explicit: Path, auto: Path) -> tuple[float, int]:
    """Return the explicit run's segmentation CPU (s) on the frames the auto run reused, and
    how many it reused."""
    import pyarrow.parquet as pq

    from superlane_tools.reporting.layout import RunLayout

    column = "segmentation_cpu_ms"
    base = pq.read_table(RunLayout(explicit).frames).column(column).to_numpy()
    ran = pq.read_table(RunLayout(auto).frames).column(column).to_numpy()
    reused = ran < 1.0  # taken from the sample: a pixel comparison, no inference
    return float(base[reused].sum() - ran[reused].sum()) / 1e3, int(reused.sum())


def _same_tables(run_a: Path, run_b: Path) -> bool:
    """Whether two runs' tables are equal cell by cell (``pipelines/compare_runs.py``)."""
    import runpy

    from superlane_tools.reporting.layout import REPORT_FILE

    compare = runpy.run_path(str(REPO / "pipelines" / "compare_runs.py"))["compare_runs"]
    _, diffs = compare(run_a, run_b)
    return not [d for d in diffs if not d.startswith(REPORT_FILE)]  # its self-check lines


def main() -> None:
    """Run the benchmark and write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--recording", type=Path, default=REPO / "fixtures" / "sample_drive.mcap")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=RESULTS, help="results JSON")
    args = parser.parse_args()
    from superlane_tools.commands.reprocess import reprocess
    from superlane_tools.drive.config import ReprocessConfig

    auto = ReprocessConfig()
    uptime_before = uptime()
    print(uptime_before, flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        reprocess(args.recording, Path(tmp) / "warmup", auto)
        chosen = _check(Path(tmp) / "warmup")
        seg = replace(auto.segmentation, backend=chosen["backend"], model=chosen["model"])
        explicit = replace(auto, segmentation=seg)
        added, check_cpu, base_cpu, auto_cpu, loads, same = [], [], [], [], [], True
        bound, reused = [], 0
        for k in range(args.repeats):
            loads.append(round(os.getloadavg()[0], 2))
            base = reprocess(args.recording, Path(tmp) / f"base{k}", explicit)
            run = reprocess(args.recording, Path(tmp) / f"auto{k}", auto)
            base_cpu.append(base.timings["cpu_total"])
            auto_cpu.append(run.timings["cpu_total"])
            added.append(auto_cpu[-1] - base_cpu[-1])
            check_cpu.append(float(_check(Path(tmp) / f"auto{k}")["cpu_s"]))
            saved, reused = _saved_segmentation_s(Path(tmp) / f"base{k}", Path(tmp) / f"auto{k}")
            bound.append(check_cpu[-1] - saved)
            same = same and _same_tables(Path(tmp) / f"base{k}", Path(tmp) / f"auto{k}")
            print(
                f"pair {k}: explicit {base_cpu[-1]:.2f} s CPU, auto {auto_cpu[-1]:.2f} s CPU "
                f"(+{added[-1]:.2f} s; self-check {check_cpu[-1]:.2f} s, of it saved in the pass "
                f"{check_cpu[-1] - bound[-1]:.2f} s on {reused} frames)",
                flush=True,
            )
        loads.append(round(os.getloadavg()[0], 2))
        frames = run.frames
    out = {
        "recording": str(args.recording.relative_to(REPO))
        if args.recording.is_relative_to(REPO)
        else str(args.recording),
        "frames": frames,
        "chosen": f"{chosen['backend']}:{chosen['model']}"
        if chosen["model"]
        else chosen["backend"],
        "candidates_tried": [t["model"] or t["backend"] for t in chosen.get("trials", [])],
        "cpus": os.cpu_count(),
        "uptime_before": uptime_before,
        "uptime_after": uptime(),
        "load_average_1min": loads,
        "added_cpu_s_median": round(statistics.median(added), 3),
        "added_cpu_s_all": [round(a, 3) for a in added],
        "self_check_cpu_s_median": round(statistics.median(check_cpu), 3),
        "added_cpu_s_bound_median": round(statistics.median(bound), 3),
        "added_cpu_s_bound_all": [round(b, 3) for b in bound],
        "frames_reused": reused,
        "explicit_cpu_s_median": round(statistics.median(base_cpu), 3),
        "auto_cpu_s_median": round(statistics.median(auto_cpu), 3),
        "cpu_ratio_auto_to_explicit": round(
            statistics.median(auto_cpu) / statistics.median(base_cpu), 4
        ),
        "tables_identical": same,
        "note": "added_cpu_s = process CPU of reprocess with the auto backend minus that of the "
        "same run with the chosen backend given explicitly (the self-check's cost to the drive, "
        "after the pass reused the chosen candidate's loaded model and segmented sample frames); "
        "self_check_cpu_s = the check's own CPU (provenance cpu_s), before that reuse; "
        "added_cpu_s_bound = self_check_cpu_s minus the explicit run's segmentation thread CPU on "
        "the frames the auto run reused (an upper bound: the saved ONNX session is not counted).",
    }
    write_results(out, args.out)


if __name__ == "__main__":
    main()
