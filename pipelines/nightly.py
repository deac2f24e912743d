"""Nightly fleet reprocessing: new recordings (or a manifest) -> `slt batch` -> fleet summary.

Finds the recordings under ``--source`` modified since the last successful run (a watermark in
the state file) and older than ``--settle-min`` minutes (so files still being copied are left
for the next night), or reads ``--manifest``; runs the batch into ``--out``; writes
``OUT/summary/``. Recordings already done are skipped by the batch itself, so overlapping or
repeated runs are harmless.

With ``--baseline ROOT`` (an earlier output root, e.g. the production model's), the night's
root is compared with it (``slt compare``: ``OUT/summary/compare/``), the frames worth labelling
are mined (``slt mine`` with the comparison's spans: ``OUT/summary/mined/``) and both go into
the fleet summary report. ``--fail-on-regression KPI[:THRESHOLD]`` (repeatable) gates on it.
The night's fleet KPIs and its comparison are then appended to the fleet's history,
``HISTORY/history/night=NIGHT/`` (``--history``, default ``--out``; ``--night``, default
today's UTC date), which ``slt history HISTORY`` plots night over night. Without
``--baseline``, ``--history DIR`` appends the night's fleet summary alone (reprocess jobs).

Exit codes: 0 when the night's work was done, even if some recordings were corrupt (they are
listed in ``OUT/batch_status.parquet`` and the report); 1 on a systemic failure: more than
``--max-failed`` of the attempted recordings failed, or the output root is unwritable or locked
by another run; 2 on a bad command line; 4 when a KPI named by ``--fail-on-regression``
regressed against the baseline, 3 when that gate cannot decide (too few drives,
nothing matched: ``slt compare``'s rules; the night's outputs and reports are written in both
cases). The watermark only
advances after a run without systemic failure.

Usage:
    python pipelines/nightly.py --source /data/drives --out /data/runs
        [--manifest FILE] [--state FILE] [--engine local|ray] [--workers N]
        [--ray-address auto] [--job reprocess|extract] [--config FILE] [--retries 1]
        [--settle-min 10] [--max-failed 0.5]
        [--baseline ROOT [--fail-on-regression KPI[:THRESHOLD]] [--mine 50]
         [--max-per-drive 10] [--history DIR] [--night YYYY-MM-DD]]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from superlane_tools.commands.batch import (
    BatchEntry,
    BatchError,
    BatchParams,
    default_kind,
    find_recordings,
    load_config_file,
    read_manifest,
    run_batch,
)
from superlane_tools.commands.batch.manifest import fingerprint
from superlane_tools.errors import SltError, UsageError
from superlane_tools.fleet import verdict_table
from superlane_tools.reporting import write_text_atomic
from superlane_tools.reporting.layout import NIGHTLY_STATE_FILE

STATE_FILE = NIGHTLY_STATE_FILE


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--source", type=Path, help="folder searched recursively for recordings")
    src.add_argument("--manifest", type=Path, help="CSV/Parquet/YAML manifest of recordings")
    ap.add_argument("--out", type=Path, required=True, help="output root (shared storage)")
    ap.add_argument("--state", type=Path, help=f"state file (default OUT/{STATE_FILE})")
    ap.add_argument("--engine", default="local", choices=("local", "ray"))
    ap.add_argument("--workers", type=int)
    ap.add_argument("--ray-address")
    ap.add_argument("--job", choices=("reprocess", "extract"))
    ap.add_argument("--config", type=Path, help="job configuration (TOML/YAML/JSON)")
    ap.add_argument("--retries", type=int, default=1)
    ap.add_argument(
        "--settle-min",
        type=float,
        default=10.0,
        help="skip files modified in the last N minutes (still being copied)",
    )
    ap.add_argument(
        "--max-failed",
        type=float,
        default=0.5,
        help="failed fraction above which the night counts as a systemic failure",
    )
    ap.add_argument("--baseline", type=Path, help="output root to compare tonight's fleet with")
    ap.add_argument(
        "--fail-on-regression",
        action="append",
        default=[],
        metavar="KPI[:THRESHOLD]",
        help="exit 4 when this KPI is worse than in the baseline (see slt compare)",
    )
    ap.add_argument("--mine", type=int, default=50, help="frames to mine (0: none)")
    ap.add_argument(
        "--max-per-drive", type=int, default=10, help="most mined frames of one drive (0: no cap)"
    )
    ap.add_argument(
        "--history",
        type=Path,
        help="nightly root whose history/ dataset the night is appended to (default: --out)",
    )
    ap.add_argument(
        "--night",
        default=time.strftime("%Y-%m-%d", time.gmtime()),
        help="the night's name in the history, YYYY-MM-DD (default: today, UTC)",
    )
    return ap.parse_args(argv)


def compare_with_baseline(args: argparse.Namespace) -> int:
    """Compare the night's root with ``--baseline``, mine frames, rewrite the fleet summary."""
    from superlane_tools.commands.batch import write_summary
    from superlane_tools.commands.compare import CompareParams, compare_runs
    from superlane_tools.commands.mine import mine_runs
    from superlane_tools.fleet import parse_rule
    from superlane_tools.fleet.history import record_night
    from superlane_tools.fleet.mining import MineParams
    from superlane_tools.reporting.layout import SUMMARY_DIR, CompareLayout, SummaryLayout
    from superlane_tools.reporting.report import Section

    layout = SummaryLayout(args.out / SUMMARY_DIR)
    command = " ".join(["nightly.py", *sys.argv[1:]])
    params = CompareParams(
        gate=tuple(parse_rule(r) for r in args.fail_on_regression), command=command
    )
    result = compare_runs(args.baseline, args.out, layout.comparison, params)
    report = CompareLayout(layout.comparison).report.relative_to(layout.root).as_posix()
    fleet = result.comparison.fleet_rows()
    sections = [
        Section(
            f"Comparison with the baseline {args.baseline}",
            [
                f"Full comparison: `{report}` "
                f"({len(result.comparison.matched)} matched drives; "
                f"{(fleet['verdict'] == 'worse').sum()} KPIs worse, "
                f"{(fleet['verdict'] == 'better').sum()} better).",
                *[
                    f"- differs: {r.what} {r.key}: {r.base} -> {r.candidate}"
                    for r in result.differences.itertuples(index=False)
                ],
                *[f"- regression: {line}" for line in result.regressions],
            ],
            [verdict_table(fleet)],
        )
    ]
    if args.mine > 0:
        mined = mine_runs(
            [args.out],
            layout.mined,
            MineParams(max_frames=args.mine, max_per_drive=args.max_per_drive or None),
            compare_dir=layout.comparison,
            command=command,
        )
        manifest = mined.manifest
        shown = (
            manifest[["drive", "frame_index", "reasons", "score"]] if len(manifest) else manifest
        )
        sections.append(
            Section(
                "Frames worth labelling",
                [
                    f"{len(manifest)} frames with pre-annotations in `{layout.mined.name}/` "
                    "(TuSimple labels.json, CULane .lines.txt, manifest.parquet)."
                ],
                [shown.head(20)],
            )
        )
    write_summary(args.out, command, sections)
    history = record_night(
        args.history or args.out,
        args.night,
        args.out,
        compare_dir=layout.comparison,
        baseline=args.baseline,
        command=command,
    )
    print(f"nightly: history: appended {len(history)} files for {args.night}")
    print(f"nightly: compared with {args.baseline}: {len(result.regressions)} regressions")
    for line in result.regressions:
        print(f"nightly: regression: {line}", file=sys.stderr)
    if result.regressions:
        return 4
    for line in result.gate.undecided:  # a gate never passes what it could not judge
        print(f"nightly: gate cannot decide: {line}", file=sys.stderr)
    return 3 if result.gate.gated and result.gate.undecided else 0


def read_state(path: Path) -> dict[str, object]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as err:
        raise BatchError(f"cannot read state file {path}: {err}") from err
    return data if isinstance(data, dict) else {}


def new_recordings(source: Path, after_ns: int, before_ns: int) -> list[BatchEntry]:
    """Recordings under ``source`` whose newest file time is in ``(after_ns, before_ns]``."""
    if not source.is_dir():
        raise UsageError(f"source folder {source} does not exist")
    found = []
    for path in find_recordings(source):
        _, mtime_ns = fingerprint(path)
        if after_ns < mtime_ns <= before_ns:
            found.append(BatchEntry(path))
    return found


def run(args: argparse.Namespace) -> int:
    if args.baseline is not None:  # bad gate rules or a missing baseline: before any work
        from superlane_tools.fleet import parse_rule

        for rule in args.fail_on_regression:
            parse_rule(rule)
        if not args.baseline.is_dir():
            raise UsageError(f"--baseline {args.baseline}: no such folder")
    if args.baseline is not None or args.history is not None:
        from superlane_tools.fleet import FleetError
        from superlane_tools.fleet.history import check_night

        try:
            check_night(args.night)
        except FleetError as err:
            raise UsageError(f"--night: {err}") from err
    state_path = args.state or args.out / STATE_FILE
    state = read_state(state_path)
    cutoff_ns = time.time_ns() - int(args.settle_min * 60e9)
    if args.manifest is not None:
        entries = read_manifest(args.manifest)
    else:
        watermark = int(state.get("watermark_ns", 0))  # type: ignore[call-overload]
        entries = new_recordings(args.source, watermark, cutoff_ns)
    if not entries:
        print("nightly: nothing new to process")
        state.update(last_run_ns=time.time_ns(), last_counts={})
        args.out.mkdir(parents=True, exist_ok=True)
        write_text_atomic(state_path, json.dumps(state, indent=1))
        return 0
    params = BatchParams(
        root=args.out,
        kind=args.job or default_kind(),
        engine=args.engine,
        workers=args.workers,
        retries=args.retries,
        config=load_config_file(args.config) if args.config else {},
        ray_address=args.ray_address,
        command=" ".join(["nightly.py", *sys.argv[1:]]),
    )
    report = run_batch(entries, params)
    counts = ", ".join(f"{k} {v}" for k, v in report.counts.items())
    print(f"nightly: {counts} in {report.wall_s:.1f} s -> {report.root}")
    for rid, reason in report.failures:
        print(f"nightly: failed: {rid}: {reason}", file=sys.stderr)
    if report.failed_fraction > args.max_failed:
        print(
            f"nightly: systemic failure: {report.failed_fraction:.0%} of the recordings failed "
            f"(limit {args.max_failed:.0%}); the watermark stays for the next run",
            file=sys.stderr,
        )
        return 1
    state.update(last_run_ns=time.time_ns(), last_counts=dict(report.counts))
    if args.manifest is None:
        state["watermark_ns"] = cutoff_ns
    write_text_atomic(state_path, json.dumps(state, indent=1))
    if args.baseline is not None:
        return compare_with_baseline(args)
    if args.history is not None:  # no comparison tonight: the fleet summary alone
        from superlane_tools.fleet.history import record_night

        record_night(args.history, args.night, args.out, command=params.command)
        print(f"nightly: history: appended the fleet summary for {args.night}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        return run(args)
    except BatchError as err:  # unwritable or locked root, engine unavailable: systemic
        print(f"nightly: systemic failure: {err}", file=sys.stderr)
        return 1
    except UsageError as err:
        print(f"nightly: error: {err}", file=sys.stderr)
        return 2
    except SltError as err:
        print(f"nightly: systemic failure: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
