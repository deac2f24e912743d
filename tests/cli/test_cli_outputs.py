"""One policy for existing outputs, on every command that writes one (README: conventions).

An existing output (a file, or a folder that is not empty) is refused without ``--overwrite``:
exit 2, one ``slt: error: COMMAND: ...`` line naming ``--overwrite``, nothing written. With
``--overwrite`` the new output replaces the old one whole: nothing of the old one is left.
The walk over the command tree keeps the list of writing commands complete.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import typer.main
from typer.testing import CliRunner

from superlane_tools.cli import app
from superlane_tools.recording import messages as m
from superlane_tools.recording.writers import open_writer

runner = CliRunner()
T0 = 1_700_000_000_000_000_000
Args = Callable[[Path, Path], list[str]]
"""``(inputs folder, output) -> arguments`` of one command."""


def _file(folder: Path, name: str) -> str:
    path = folder / name
    path.write_text("input")
    return str(path)


def _dir(folder: Path, name: str) -> str:
    path = folder / name
    path.mkdir(exist_ok=True)
    (path / "a.png").write_text("input")
    return str(path)


WRITERS: dict[str, tuple[str, Args]] = {
    # command: (what the output is, arguments with dummy inputs: the refusal comes first)
    "reprocess": ("folder", lambda i, o: [_file(i, "d.mcap"), "-o", str(o)]),
    "camera calibrate": ("file", lambda i, o: [_dir(i, "boards"), "-o", str(o)]),
    "camera estimate": ("file", lambda i, o: [_file(i, "d.mcap"), "-o", str(o)]),
    "camera from-kitti": ("file", lambda i, o: [_file(i, "calib.txt"), "--out", str(o)]),
    "compare": ("folder", lambda i, o: [_dir(i, "base"), _dir(i, "cand"), "-o", str(o)]),
    "convert": ("file", lambda i, o: [_file(i, "g.nmea"), "-o", str(o)]),
    "corridor": ("folder", lambda i, o: [_dir(i, "images"), "-o", str(o)]),
    "extract": ("folder", lambda i, o: [_file(i, "d.mcap"), "-o", str(o)]),
    "filter": ("file", lambda i, o: [_file(i, "d.mcap"), "-o", str(o)]),
    "lanes fit": (
        "file",
        lambda i, o: [_dir(i, "seg"), "--camera", "tusimple", "--out", str(o)],
    ),
    "lanes export-tusimple": (
        "file",
        lambda i, o: [_file(i, "l.parquet"), "--camera", "tusimple", "--out", str(o)],
    ),
    "lanes export-kitti": (
        "folder",
        lambda i, o: [_file(i, "l.parquet"), "--camera", "tusimple", "--out", str(o)],
    ),
    "mine": ("folder", lambda i, o: [_dir(i, "run"), "-o", str(o)]),
    "history": ("folder", lambda i, o: [_dir(i, "root"), "-o", str(o)]),
    "recover": ("file", lambda i, o: [_file(i, "d.mcap"), "-o", str(o)]),
    "segment": ("folder", lambda i, o: [_dir(i, "images"), "-o", str(o)]),
    "simulate": ("file", lambda _, o: ["-s", "highway_straight", "-o", str(o)]),
    "simulate dataset": ("folder", lambda _, o: ["--frames", "2", "-o", str(o)]),
    "tables availability": ("file", lambda i, o: [_dir(i, "run"), "-o", str(o)]),
    "tables curvature": ("file", lambda i, o: [_dir(i, "run"), "-o", str(o)]),
    "tables paper": ("file", lambda i, o: [_file(i, "r.json"), "-o", str(o)]),
    "train": ("file", lambda _, o: ["segmentation", "--out", str(o)]),
    **{
        f"eval {kind}": ("file", lambda i, o: [_dir(i, "pred"), _dir(i, "gt"), "--save", str(o)])
        for kind in ("attributes", "caltech", "culane", "kitti", "tusimple")
    },
}
"""Every command that writes an output, and how to call it."""
IDEMPOTENT = {
    "batch": "an output root is reused: finished recordings are skipped (--overwrite redoes)"
}
"""Commands whose output is a root many runs share, with the reason."""


def _walk(command: Any, path: tuple[str, ...] = ()) -> list[tuple[str, Any]]:
    subs = getattr(command, "commands", None)
    found = [(" ".join(path), command)] if path else []
    for name, sub in sorted((subs or {}).items()):
        found += _walk(sub, (*path, name))
    return found


COMMANDS = dict(_walk(typer.main.get_command(app)))
OUTPUT_OPTIONS = {"--out", "--save"}


def test_every_writing_command_is_listed_and_takes_overwrite() -> None:
    writing = {
        name
        for name, cmd in COMMANDS.items()
        if any(OUTPUT_OPTIONS & set(getattr(p, "opts", ())) for p in cmd.params)
    }
    assert writing == set(WRITERS) | set(IDEMPOTENT)
    for name in writing:
        opts = {opt for p in COMMANDS[name].params for opt in getattr(p, "opts", ())}
        assert "--overwrite" in opts, name


def _existing(out: Path, kind: str) -> None:
    if kind == "folder":
        out.mkdir()
        (out / "old.txt").write_text("old")
    else:
        out.write_text("old")


def _snapshot(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): p.read_text(errors="replace") if p.is_file() else "<dir>"
        for p in sorted(folder.rglob("*"))
    }


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_an_existing_output_is_refused(name: str, tmp_path: Path) -> None:
    kind, args = WRITERS[name]
    inputs = tmp_path / "in"
    inputs.mkdir()
    out = tmp_path / ("out" if kind == "folder" else "out.mcap")
    _existing(out, kind)
    argv = [*name.split(), *args(inputs, out)]
    before = _snapshot(tmp_path)
    res = runner.invoke(app, argv)
    assert res.exit_code == 2, res.output
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert lines == [f"slt: error: {name}: {out} exists; pass --overwrite to replace it"]
    assert res.stdout == ""
    assert _snapshot(tmp_path) == before  # nothing written, nothing replaced


def test_an_empty_folder_is_not_an_existing_output(tmp_path: Path) -> None:
    log = _nmea(tmp_path / "g.nmea")
    out = tmp_path / "out"
    out.mkdir()
    res = runner.invoke(app, ["extract", str(log), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert (out / "rtk.parquet").is_file()


def test_an_output_holding_an_input_is_never_replaced(tmp_path: Path) -> None:
    folder = tmp_path / "data"
    folder.mkdir()
    log = _nmea(folder / "g.nmea")
    res = runner.invoke(app, ["extract", str(log), "-o", str(folder), "--overwrite"])
    assert res.exit_code == 2, res.output
    assert f"extract: --out {folder} holds the input {log}" in res.stderr
    assert log.is_file()
    same = runner.invoke(app, ["convert", str(log), "-o", str(log)])  # without --overwrite too
    assert same.exit_code == 2, same.output
    assert f"convert: --out {log} holds the input {log}; not replacing it" in same.stderr


# --overwrite, on real runs of the commands: the old output goes whole, nothing stale is left.


def _sentence(body: str) -> str:
    checksum = 0
    for char in body.encode():
        checksum ^= char
    return f"${body}*{checksum:02X}"


def _nmea(path: Path, n: int = 5) -> Path:
    rmc = "GNRMC,092542.00,A,4846.4008666,N,00854.7249096,E,0.011,,200420,,,R,V"
    gga = "GNGGA,0925{:02d}.00,4846.4008666,N,00854.7249096,E,4,12,0.47,419.1,M,47.5,M,0.0,0000"
    lines = [_sentence(rmc), *(_sentence(gga.format(i)) for i in range(n))]
    path.write_text("\n".join([*lines, ""]))
    return path


def _mcap(path: Path, n: int = 20) -> Path:
    with open_writer(path, "mcap", chunk_size=1024) as writer:
        writer.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(n):
            t = T0 + i * 100_000_000
            writer.write("/fix", t, m.navsatfix(t, "gnss", 48.0, 11.0, 500.0))
    return path


def _cut_mcap(path: Path) -> Path:
    full = _mcap(path.with_name("full.mcap"), 200)
    path.write_bytes(full.read_bytes()[: full.stat().st_size // 2])
    return path


def _image_folder(path: Path) -> Path:
    import cv2
    import numpy as np

    path.mkdir()
    img = np.random.default_rng(1).integers(60, 120, (90, 160, 3), dtype=np.uint8)
    cv2.imwrite(str(path / "a.png"), img)
    return path


SMALL = ["--width", "160", "--height", "90"]
SMALL = ["--width", "160", "--height", "90"]
RERUNS: dict[str, tuple[str, Callable[[Path], list[str]]]] = {
    "convert": ("out.mcap", lambda t: ["convert", str(_nmea(t / "g.nmea")), "-o"]),
    "extract": ("out", lambda t: ["extract", str(_nmea(t / "g.nmea")), "-o"]),
    "filter": ("out.mcap", lambda t: ["filter", str(_mcap(t / "d.mcap")), "-o"]),
    "recover": ("out.mcap", lambda t: ["recover", str(_cut_mcap(t / "cut.mcap")), "-o"]),
    "segment": (
        "out",
        lambda t: ["segment", str(_image_folder(t / "img")), "--backend", "classical", "-o"],
    ),
    "simulate": (
        "sim.mcap",
        lambda _: ["simulate", "-s", "highway_straight", "--duration", "0.4", *SMALL, "-o"],
    ),
}
"""Cheap real runs ``(output name, tmp -> arguments up to the output path)``."""


@pytest.mark.parametrize("name", sorted(RERUNS))
def test_overwrite_replaces_the_whole_output(name: str, tmp_path: Path) -> None:
    out_name, build = RERUNS[name]
    out = tmp_path / out_name
    argv = [*build(tmp_path), str(out)]
    first = runner.invoke(app, argv)
    assert first.exit_code in (0, 3), first.output
    assert out.exists()
    if out.is_dir():
        (out / "stale.txt").write_text("from an older run")
    refused = runner.invoke(app, argv)
    assert refused.exit_code == 2, refused.output
    again = runner.invoke(app, [*argv, "--overwrite"])
    assert again.exit_code == first.exit_code, again.output
    assert out.exists()
    assert not (out / "stale.txt").exists()  # nothing of the old output survives
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert leftovers == []  # the old output set aside is gone


@pytest.mark.slow
def test_reprocess_overwrite_replaces_the_run_folder(tmp_path: Path) -> None:
    from superlane_tools.simulation.drive import simulate_drive

    rec = tmp_path / "d.mcap"
    simulate_drive("highway_straight", 1.0, 3, "mcap", 160, 90, False, rec)
    out = tmp_path / "run"
    argv = ["reprocess", str(rec), "-o", str(out), "--no-plots", "--backend", "classical"]
    assert runner.invoke(app, argv).exit_code == 0
    (out / "stale.txt").write_text("x")
    refused = runner.invoke(app, argv)
    assert refused.exit_code == 2
    assert "reprocess: " in refused.stderr
    assert "--overwrite" in refused.stderr
    assert (out / "stale.txt").exists()
    again = runner.invoke(app, [*argv, "--overwrite"])
    assert again.exit_code == 0, again.output
    assert not (out / "stale.txt").exists()
    assert (out / "report.html").is_file()


def _dead_pid() -> int:
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    return int(done.stdout)


def test_a_killed_overwrite_leaves_the_old_output_or_the_new_one(tmp_path: Path) -> None:
    log = _nmea(tmp_path / "g.nmea")
    out = tmp_path / "out.mcap"
    pid = _dead_pid()
    aside = tmp_path / f".out.mcap.{pid}.0badc0de.old"  # killed after setting the old one aside
    aside.write_text("old output")
    refused = runner.invoke(app, ["convert", str(log), "-o", str(out)])
    assert refused.exit_code == 2  # the old output is back in place, and refused
    assert out.read_text() == "old output"
    assert not aside.exists()
    aside.write_text("older output")  # killed after the new output was written
    done = runner.invoke(app, ["convert", str(log), "-o", str(out), "--overwrite"])
    assert done.exit_code == 0, done.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.nmea", "out.mcap"]
