"""Full fuzz campaign and SIGKILL campaign of ``slt``; writes ``benchmarks/results/fuzz.json``.

Run: ``nice python benchmarks/fuzz.py [--cases 1100] [--kills 20] [--ray-kills 6] [--seed 0]``.

Cases come from ``tests/fuzz/fuzzcases.py`` (damaged MCAP, ROS 1 and ROS 2 bags, candump,
ASC, BLF and NMEA logs, mutated real DBCs, bad image frames, extreme timestamps, colliding and
long topic names, odd paths and configs; real data from ``SLT_REALDATA`` where present). Each
runs ``slt`` in a forked child with a timeout (a hang is a finding), and is classified: clean,
traceback, internal error, hang, wrong exit code, data lost beyond the damage, files outside
``--out``. Then ``extract``, ``reprocess`` and ``batch`` are each SIGKILLed at ``--kills``
random moments and rerun, and a ray-engine batch at ``--ray-kills`` (only its driver killed;
no process it started may survive); a trial passes when the rerun exits 0 with complete,
consistent outputs and nothing temporary left anywhere.

The JSON holds the summary table (overall and per family), every non-clean case with its
exit code and the tail of its stderr, the kill trials, the machine and the wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests" / "fuzz"))

import fuzzcases as fc  # noqa: E402
import fuzzcases_wave2  # noqa: E402, F401 - registers the second-wave families in fc.FAMILIES

RESULTS = HERE / "results" / "fuzz.json"
SHARE = {  # share of the cases per family; the second wave (issue 27 item 8) runs first
    "sqlite": 0.08,
    "text_junk": 0.08,
    "wrong_topic": 0.04,
    "manifest": 0.03,
    "recover": 0.08,
    "reprocess": 0.02,
    "disk_full": 0.02,
    "mcap": 0.09,
    "images": 0.07,
    "timestamps": 0.06,
    "topics": 0.04,
    "canlog": 0.08,
    "blf_asc": 0.08,
    "nmea": 0.06,
    "dbc": 0.07,
    "bags": 0.06,
    "paths_configs": 0.05,
}


def main() -> None:
    """Run both campaigns and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1100)
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument(
        "--ray-kills", type=int, default=6, help="kill trials of a ray-engine batch (0: none)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=90.0, help="seconds per case")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument(
        "--only",
        default="",
        help="comma-separated case names: rerun just those cases of the campaign (same --cases "
        "and --seed), e.g. the findings of an earlier run after a fix; no kill trials",
    )
    args = parser.parse_args()
    per_family = {f: max(1, round(args.cases * share)) for f, share in SHARE.items()}
    started = time.time()
    with tempfile.TemporaryDirectory(prefix="slt-fuzz-") as tmp:
        os.environ["SLT_FUZZ_CACHE"] = tmp
        root = Path(tmp)
        fc.preload()
        cases = fc.all_cases(per_family, seed=args.seed)
        only = {name for name in args.only.split(",") if name}
        if only:
            cases = [case for case in cases if case.name in only]
            if {case.name for case in cases} != only:
                missing = sorted(only - {case.name for case in cases})
                raise SystemExit(f"fuzz: no such case (check --cases and --seed): {missing}")
        outcomes = []
        for n, case in enumerate(cases, start=1):
            outcomes.append(fc.run_case(case, root / "cases", timeout_s=args.timeout))
            if n % 50 == 0:
                print(f"{n}/{len(cases)} cases, {time.time() - started:.0f} s", flush=True)
                _write(args, outcomes, [], time.time() - started, started, len(cases))
        fuzz_s = time.time() - started
        kills: list[dict[str, object]] = []
        commands = [] if only else [(c, args.kills) for c in ("extract", "reprocess", "batch")]
        if args.ray_kills and not only:
            commands.append(("batch-ray", args.ray_kills))
        for command, n in commands:
            t0 = time.time()
            trials = fc.kill_campaign(command, n, root, seed=args.seed)
            kills.append(
                {
                    "command": command,
                    "trials": len(trials),
                    "killed_mid_run": sum(t.killed for t in trials),
                    "complete_and_clean_after_rerun": sum(not t.problems for t in trials),
                    "failed": [asdict(t) for t in trials if t.problems],
                    "kill_times_s": [t.kill_after_s for t in trials],
                    "seconds": round(time.time() - t0, 1),
                }
            )
            print(f"kills {command}: {kills[-1]['complete_and_clean_after_rerun']}/{len(trials)}")
    result = _write(args, outcomes, kills, fuzz_s, started, len(cases))
    print(json.dumps(result["summary"]))
    print(f"wrote {args.out}")


def _write(
    args: argparse.Namespace,
    outcomes: list[fc.Outcome],
    kills: list[dict[str, object]],
    fuzz_s: float,
    started: float,
    planned: int,
) -> dict[str, object]:
    """Write the results so far (every 50 cases, so a stopped campaign still leaves them)."""
    summary = fc.summarise(outcomes)
    result = {
        "command": " ".join(["python", "benchmarks/fuzz.py", *sys.argv[1:]]),
        "data": "real public data from SLT_REALDATA (TuSimple frames, Ford Fusion candump, "
        "Mobileye and opendbc DBCs, u-blox NMEA) written into recordings with the project's "
        "writers, then damaged by the generators; the speed CSV and the GPX track of the "
        "text_junk family are synthetic",
        "machine": f"{platform.node()} {platform.machine()} {os.cpu_count()} CPUs (shared)",
        "seed": args.seed,
        "cases_planned": planned,
        "cases_run": len(outcomes),
        "timeout_s_per_case": args.timeout,
        "summary": summary["total"],
        "by_family": summary["by_family"],
        "findings": [asdict(o) for o in outcomes if o.findings != ["clean"]],
        "sigkill": kills,
        "fuzz_wall_s": round(fuzz_s, 1),
        "total_wall_s": round(time.time() - started, 1),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    work = args.out.with_name(f".{args.out.name}.tmp")
    work.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    work.replace(args.out)
    return result


if __name__ == "__main__":
    main()
