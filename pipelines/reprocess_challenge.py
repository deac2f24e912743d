"""Simulate one drive per challenge scenario, reprocess each, and build the paper tables.

Usage::

    python pipelines/reprocess_challenge.py [--work runs/challenge] [--report DIR]
        [--duration 20] [--width 640] [--height 360] [--scenarios a,b,...]

Writes into ``--report`` (default ``reports/reprocess_challenge``): ``availability.md`` /
``.tex`` (corridor paper Table II layout, by category), ``curvature.md`` (default segmentation),
``curvature_oracle.md`` (the simulator's ground-truth label images, ``--backend oracle``: the lane
stage on its own) and ``curvature_onnx.md`` (the shipped segmentation network) on the curvature
scenarios, and ``commands.txt`` (every command in order, exit code, seconds, load average).
Drives: seed 1, 15 Hz, sequences of 5 s (``reprocess_challenge.toml``). Recordings already in
``--work`` are reused (their ``slt simulate`` command is still listed). ``--simulator-path``
prepends a folder to ``PYTHONPATH`` for the ``slt simulate`` steps only (a pinned checkout).
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

SCENARIOS = (
    "sun_after_rain",
    "heavy_rain",
    "direct_sunlight",
    "faded_lines",
    "tar_seams",
    "highway_curves",
    "hills",
)
CURVATURE = ("highway_curves", "hills")
_TOML = Path(__file__).resolve().parent / "reprocess_challenge.toml"
CONFIG = Path(os.path.relpath(_TOML)) if _TOML.is_relative_to(Path.cwd()) else _TOML


def _plan(args: argparse.Namespace) -> list[tuple[list[str], bool]]:
    """Return ``(command, is_simulation)`` pairs, in order."""
    work, report = Path(args.work), Path(args.report)
    scenarios = [s for s in args.scenarios.split(",") if s]
    curv = [s for s in scenarios if s in CURVATURE]
    plan: list[tuple[list[str], bool]] = []
    for name in scenarios:
        rec = work / f"{name}.mcap"
        size = ["--width", str(args.width), "--height", str(args.height)]
        plan.append(
            (
                [
                    *("slt", "simulate", "-s", name, "-o", str(rec)),
                    *("--duration", str(args.duration), "--seed", "1", *size),
                    *(["--labels"] if name in curv else []),
                ],
                True,
            )
        )
        base = ["slt", "reprocess", str(rec), "--category", name, "--config", str(CONFIG)]
        plan.append(([*base, "--out", str(work / "runs" / name), "--no-plots"], False))
        if name in curv:
            labels = work / f"{name}_labels" / "labels"
            oracle = ["--backend", "oracle", "--oracle-labels", str(labels)]
            plan.append(
                ([*base, "--out", str(work / "oracle" / name), "--no-plots", *oracle], False)
            )
            plan.append(
                (
                    [*base, "--out", str(work / "onnx" / name), "--no-plots", "--backend", "onnx"],
                    False,
                )
            )
    runs = [str(work / "runs" / n) for n in scenarios]
    table = ["slt", "tables"]
    for suffix in (".md", ".tex"):
        out = str(report / f"availability{suffix}")
        plan.append(([*table, "availability", *runs, "--by", "category", "--out", out], False))
    if curv:
        for folder, name in (("runs", "curvature"), ("oracle", "curvature_oracle")):
            dirs = [str(work / folder / n) for n in curv]
            plan.append(([*table, "curvature", *dirs, "--out", str(report / f"{name}.md")], False))
        dirs = [str(work / "onnx" / n) for n in curv]
        plan.append(
            ([*table, "curvature", *dirs, "--out", str(report / "curvature_onnx.md")], False)
        )
    return plan


def _run(cmd: list[str], simulate: bool, args: argparse.Namespace) -> tuple[int, str]:
    """Run one ``slt`` command with this interpreter's ``slt``; return exit code and stderr."""
    slt = Path(sys.executable).with_name("slt")
    env = dict(os.environ)
    if simulate and args.simulator_path:
        env["PYTHONPATH"] = os.pathsep.join(
            filter(None, [args.simulator_path, env.get("PYTHONPATH")])
        )
    done = subprocess.run(  # every command of the plan writes: replace the previous run's
        [str(slt), *cmd[1:], "--overwrite"], check=False, capture_output=True, text=True, env=env
    )
    return done.returncode, done.stderr


def main(argv: list[str] | None = None) -> int:
    """Run the whole set, write the tables and ``commands.txt``; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", default="runs/challenge", help="recordings and runs")
    parser.add_argument("--report", default="reports/reprocess_challenge", help="tables folder")
    parser.add_argument("--duration", type=float, default=20.0, help="seconds per drive")
    parser.add_argument("--width", type=int, default=640, help="image width, pixels")
    parser.add_argument("--height", type=int, default=360, help="image height, pixels")
    parser.add_argument("--scenarios", default=",".join(SCENARIOS), help="comma-separated")
    parser.add_argument("--simulator-path", default="", help="PYTHONPATH for slt simulate only")
    args = parser.parse_args(argv)
    Path(args.work).mkdir(parents=True, exist_ok=True)
    report = Path(args.report)
    report.mkdir(parents=True, exist_ok=True)
    log = [f"# {time.strftime('%Y-%m-%d %H:%M')}, load average {os.getloadavg()[0]:.1f} at start"]
    start = time.perf_counter()
    cpu_start = os.times()
    for cmd, simulate in _plan(args):
        if simulate and Path(cmd[cmd.index("-o") + 1]).exists():
            log.append(f"{shlex.join(cmd)}  # recording present, reused")
            print(log[-1], flush=True)
            continue
        t0 = time.perf_counter()
        code, err = _run(cmd, simulate, args)
        log.append(f"{shlex.join(cmd)}  # exit {code}, {time.perf_counter() - t0:.1f} s")
        print(log[-1], flush=True)
        if code not in (0, 3):
            print(err, file=sys.stderr)
            return code
    cpu = os.times()
    cpu_s = (cpu.children_user + cpu.children_system) - (
        cpu_start.children_user + cpu_start.children_system
    )
    log.append(
        f"# total {time.perf_counter() - start:.0f} s wall, {cpu_s:.0f} s CPU, "
        f"load average {os.getloadavg()[0]:.1f} at the end"
    )
    (report / "commands.txt").write_text("\n".join(log) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
