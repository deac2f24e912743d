"""Simulate one short drive per challenge scenario, reprocess each, and build the paper tables.

Usage: ``python pipelines/reprocess_challenge.py [WORK_DIR]`` (default ``runs/challenge``).
Writes ``reports/reprocess_challenge/{availability,curvature,curvature_oracle}.md`` and
``commands.txt`` (every command, in order). Drives: 10 s, 640x360, seed 1,
sequences of 5 s (``reprocess_challenge.toml``); the lane stage is
also measured with the simulator's ground-truth label images (``--backend oracle``) on
``highway_curves`` and ``hills``.
"""

from __future__ import annotations

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
ORACLE = ("highway_curves", "hills")
REPORT = Path("reports/reprocess_challenge")
CONFIG = Path("pipelines/reprocess_challenge.toml")


def _argv(cmd: list[str]) -> list[str]:
    """Run ``slt reprocess|tables`` through this script until the lead wires them into ``slt``."""
    if cmd[1] in ("reprocess", "tables"):
        return [sys.executable, __file__, "--cli", *cmd[1:]]
    return cmd


def _cli(args: list[str]) -> None:
    import typer

    from superlane_tools.cli import reprocess, tables

    app = typer.Typer(pretty_exceptions_show_locals=False)
    reprocess.register(app)
    tables.register(app)
    app(args, prog_name="slt")


def main() -> None:
    """Run the whole set and write the tables."""
    if len(sys.argv) > 1 and sys.argv[1] == "--cli":
        _cli(sys.argv[2:])
        return
    work = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/challenge")
    work.mkdir(parents=True, exist_ok=True)
    REPORT.mkdir(parents=True, exist_ok=True)
    commands: list[list[str]] = []
    for name in SCENARIOS:
        rec = work / f"{name}.mcap"
        if not rec.exists():
            commands.append(
                [
                    "slt",
                    "simulate",
                    "-s",
                    name,
                    "-o",
                    str(rec),
                    "--duration",
                    "10",
                    "--seed",
                    "1",
                    "--width",
                    "640",
                    "--height",
                    "360",
                    *(["--labels"] if name in ORACLE else []),
                ]
            )
        commands.append(
            [
                "slt",
                "reprocess",
                str(rec),
                "--out",
                str(work / "runs" / name),
                "--category",
                name,
                "--no-plots",
                "--config",
                str(CONFIG),
            ]
        )
        if name in ORACLE:
            commands.append(
                [
                    "slt",
                    "reprocess",
                    str(rec),
                    "--out",
                    str(work / "oracle" / name),
                    "--category",
                    name,
                    "--no-plots",
                    "--config",
                    str(CONFIG),
                    "--backend",
                    "oracle",
                    "--oracle-labels",
                    str(work / f"{name}_labels" / "labels"),
                ]
            )
    runs = [str(work / "runs" / n) for n in SCENARIOS]
    oracle = [str(work / "oracle" / n) for n in ORACLE]
    commands += [
        [
            "slt",
            "tables",
            "availability",
            *runs,
            "--by",
            "category",
            "--out",
            str(REPORT / "availability.md"),
        ],
        [
            "slt",
            "tables",
            "availability",
            *runs,
            "--by",
            "category",
            "--out",
            str(REPORT / "availability.tex"),
        ],
        ["slt", "tables", "curvature", *runs, "--out", str(REPORT / "curvature.md")],
        ["slt", "tables", "curvature", *oracle, "--out", str(REPORT / "curvature_oracle.md")],
    ]
    log = []
    start = time.perf_counter()
    for cmd in commands:
        t0 = time.perf_counter()
        done = subprocess.run(_argv(cmd), check=False, capture_output=True, text=True)
        log.append(f"{shlex.join(cmd)}  # exit {done.returncode}, {time.perf_counter() - t0:.1f} s")
        print(log[-1], flush=True)
        if done.returncode not in (0, 3):
            print(done.stderr, file=sys.stderr)
            raise SystemExit(done.returncode)
    log.append(f"# total {time.perf_counter() - start:.0f} s wall")
    (REPORT / "commands.txt").write_text("\n".join(log) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
