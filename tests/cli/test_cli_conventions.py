"""CLI conventions, checked on every registered command and group (whoever registers it).

The walk starts at the root Typer app, so commands added later are checked without editing
this file: ``-h`` everywhere, ``-o`` for every ``--out``, metavars that are words (not Python
types), shown defaults, bad option values exit 2, stderr messages one line each, skipped items
aggregated per kind, and a progress report on stderr when it is not a terminal.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import typer.main
from typer.testing import CliRunner

from superlane_tools.cli import app
from superlane_tools.cli._common import err_console, first_sentence, progress, report_skipped
from superlane_tools.errors import ExitCode
from superlane_tools.records import Skipped

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "fixtures" / "sample_drive.mcap"
runner = CliRunner()


def _walk(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    yield path, command
    for name, sub in sorted(getattr(command, "commands", {}).items()):
        yield from _walk(sub, (*path, name))


ROOT = typer.main.get_command(app)
COMMANDS = list(_walk(ROOT))
IDS = [" ".join(path) or "slt" for path, _ in COMMANDS]
TYPE_METAVAR = re.compile(r"<(path|str|int|float|bool|file|dir|list\[|tuple|\w+ range)", re.I)


def _options(command: Any) -> list[Any]:
    return [p for p in command.params if p.param_type_name == "option"]


def test_the_walk_finds_the_commands() -> None:
    names = {" ".join(path) for path, _ in COMMANDS}
    expected = {"reprocess", "batch", "extract", "camera list", "lanes fit", "simulate dataset"}
    assert expected <= names
    assert len(COMMANDS) >= 15


@pytest.mark.parametrize(("path", "command"), COMMANDS, ids=IDS)
def test_short_help_metavars_and_defaults(path: tuple[str, ...], command: Any) -> None:
    short = runner.invoke(app, [*path, "-h"])
    assert short.exit_code == 0, short.output
    assert short.output.startswith("Usage: slt")
    assert short.output == runner.invoke(app, [*path, "--help"]).output
    text = short.output
    assert not TYPE_METAVAR.search(text), f"Python type shown as a metavar: {text}"
    for param in command.params:
        if param.param_type_name == "argument":
            assert param.metavar, param.name
            assert param.metavar.isupper(), param.name
        elif not getattr(param, "is_flag", False) and param.metavar is not None:
            assert not TYPE_METAVAR.search(param.metavar), (param.name, param.metavar)
    defaults = [
        p
        for p in _options(command)
        if p.default not in (None, False, (), [], "")  # click shows no empty default
        and p.show_default is not False
        and not getattr(p, "is_flag", False)
        and not p.hidden
    ]
    assert " ".join(text.split()).count("[default:") + text.count("; default:") >= len(defaults)


GROUPS = [(path, cmd) for path, cmd in COMMANDS if getattr(cmd, "commands", None)]


@pytest.mark.parametrize(("path", "group"), GROUPS, ids=[" ".join(p) or "slt" for p, _ in GROUPS])
def test_command_lists_show_whole_first_sentences(path: tuple[str, ...], group: Any) -> None:
    text = runner.invoke(app, [*path, "-h"]).output
    listing = "".join(text.split("Commands:", 1)[1].split())  # wrapped anywhere, even at "-"
    assert "..." not in listing, text
    for name, sub in group.commands.items():
        help_text = " ".join((sub.help or "").split("\n\n")[0].split())
        sentence = first_sentence(sub.help or "")
        assert sentence, name
        assert help_text.startswith(sentence), (name, sentence)
        assert name + "".join(sentence.split()) in listing, (name, sentence, text)


@pytest.mark.parametrize(("path", "command"), COMMANDS, ids=IDS)
def test_every_out_option_has_short_o(path: tuple[str, ...], command: Any) -> None:
    for option in _options(command):
        if "--out" in option.opts:
            assert "-o" in option.opts, f"slt {' '.join(path)}: --out without -o"
            assert "-o, --out" in runner.invoke(app, [*path, "-h"]).output


def _with_option(name: str) -> list[tuple[tuple[str, ...], Any]]:
    return [(path, cmd) for path, cmd in COMMANDS if any(name in p.opts for p in _options(cmd))]


@pytest.mark.parametrize(
    ("path", "command"),
    _with_option("--camera"),
    ids=[" ".join(p) for p, _ in _with_option("--camera")],
)
def test_bad_camera_is_a_usage_error(path: tuple[str, ...], command: Any) -> None:
    res = runner.invoke(app, [*path, "--camera", "nope"])
    assert res.exit_code == 2, res.output
    assert "Invalid value for '--camera'" in res.output
    assert "Traceback" not in res.output


INPUT_FILE_OPTIONS = ("--dbc", "--config", "--manifest", "--classes")


@pytest.mark.parametrize("option", INPUT_FILE_OPTIONS)
def test_missing_input_file_is_a_usage_error(option: str, tmp_path: Path) -> None:
    found = _with_option(option)
    assert found, option
    for path, _ in found:
        res = runner.invoke(app, [*path, option, str(tmp_path / "missing.file")])
        assert res.exit_code == 2, (path, res.output)
        assert f"Invalid value for '{option}'" in res.output, (path, res.output)


@pytest.mark.parametrize(
    "args",
    [
        ["--camera", "nope"],
        ["--dbc", "/missing.dbc"],
        ["--backend", "foo"],
        ["--config", "/missing.yaml"],
    ],
    ids=["camera", "dbc", "backend", "config"],
)
def test_reprocess_bad_values_exit_2(args: list[str], tmp_path: Path) -> None:
    res = runner.invoke(app, ["reprocess", str(SAMPLE), "-o", str(tmp_path / "run"), *args])
    assert res.exit_code == 2, res.output
    assert not (tmp_path / "run").exists()


def test_error_lines_are_never_wrapped(tmp_path: Path) -> None:
    deep = tmp_path.joinpath(*(["a_rather_long_folder_name"] * 8), "missing_recording.mcap")
    res = runner.invoke(app, ["info", str(deep)])
    assert res.exit_code == 1
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("slt: error:")
    assert str(deep) in lines[0]
    assert len(lines[0]) > 200


def test_skipped_lines_aggregate_per_kind(capsys: pytest.CaptureFixture[str]) -> None:
    items = [Skipped("bad NMEA checksum", f"g.nmea: line {i} " + "x" * 90, 1) for i in range(11)]
    items.append(Skipped("corrupt chunk", "offset 1234", 0))
    assert report_skipped(items) == ExitCode.PARTIAL
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        "slt: skipped: bad NMEA checksum (11): g.nmea: line 0 " + "x" * 90 + "; and 10 more",
        "slt: skipped: corrupt chunk: offset 1234",
    ]
    assert report_skipped([]) == ExitCode.OK


def _sentence(body: str) -> str:
    checksum = 0
    for char in body.encode():
        checksum ^= char
    return f"${body}*{checksum:02X}"


def test_extract_reports_eleven_bad_checksums_on_one_line(tmp_path: Path) -> None:
    rmc = "GNRMC,092542.00,A,4846.4008666,N,00854.7249096,E,0.011,,200420,,,R,V"
    gga = "GNGGA,092542.00,4846.4008666,N,00854.7249096,E,4,12,0.47,419.166,M,47.535,M,0.0,0000"
    bad = [_sentence(gga.replace("092542.00", f"0926{i:02d}.00"))[:-2] + "00" for i in range(11)]
    log = tmp_path / "g.nmea"
    log.write_text("\n".join([_sentence(rmc), _sentence(gga), *bad, ""]))
    res = runner.invoke(app, ["extract", str(log), "-o", str(tmp_path / "out")])
    assert res.exit_code == 3, res.output
    skipped = [line for line in res.stderr.splitlines() if line.startswith("slt: skipped:")]
    assert len(skipped) == 1, res.stderr
    assert "(11)" in skipped[0]


def test_progress_is_a_periodic_line_when_not_a_terminal(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    assert not err_console.is_terminal  # pytest captures stderr
    monkeypatch.setenv("SLT_PROGRESS_INTERVAL_S", "0")
    with progress("reprocess", 4, "frames") as bar:
        for _ in range(4):
            bar.advance()
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 4
    assert lines[-1].startswith("slt: progress: reprocess 4/4 frames (100%)")
    monkeypatch.setenv("SLT_PROGRESS_INTERVAL_S", "3600")
    with progress("quiet", 4) as bar:
        bar.update(2)
    assert capsys.readouterr().err == ""


def test_simulate_prints_progress_lines_on_a_pipe(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("SLT_PROGRESS_INTERVAL_S", "0")
    out = tmp_path / "d.mcap"
    args = ["simulate", "-s", "highway_straight", "--duration", "1", "--width", "160"]
    res = runner.invoke(app, [*args, "--height", "90", "-o", str(out)])
    assert res.exit_code == 0, res.output
    lines = [line for line in res.stderr.splitlines() if line.startswith("slt: progress:")]
    assert lines, res.stderr
    assert re.match(r"slt: progress: simulate highway_straight \d+/15 frames", lines[-1])
    assert "slt: progress" not in res.stdout
