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


def _bad_checksum_log(tmp_path: Path, n_bad: int = 3) -> Path:
    rmc = "GNRMC,092542.00,A,4846.4008666,N,00854.7249096,E,0.011,,200420,,,R,V"
    gga = "GNGGA,092542.00,4846.4008666,N,00854.7249096,E,4,12,0.47,419.166,M,47.535,M,0.0,0000"
    bad = [_sentence(gga.replace("092542.00", f"0926{i:02d}.00"))[:-2] + "00" for i in range(n_bad)]
    log = tmp_path / "g.nmea"
    log.write_text("\n".join([_sentence(rmc), _sentence(gga), *bad, ""]))
    return log


def test_extract_reports_eleven_bad_checksums_on_one_line(tmp_path: Path) -> None:
    log = _bad_checksum_log(tmp_path, 11)
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


# The README's contract on every command: a usage error or bad value is one `slt: error:` line
# and exit 2; a partial result is exit 3 with one `slt: skipped:` line per kind (with a count);
# every line on stderr carries one of the four prefixes.

LEAVES = [(path, cmd) for path, cmd in COMMANDS if not getattr(cmd, "commands", None)]
LEAF_IDS = [" ".join(path) for path, _ in LEAVES]
PREFIXES = ("slt: error: ", "slt: skipped: ", "slt: note: ", "slt: progress: ")


def _stderr_lines(res: Any) -> list[str]:
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert all(line.startswith(PREFIXES) for line in lines), res.stderr
    return lines


@pytest.mark.parametrize(("path", "command"), LEAVES, ids=LEAF_IDS)
def test_unknown_option_is_one_line_exit_2(path: tuple[str, ...], command: Any) -> None:
    res = runner.invoke(app, [*path, "--no-such-option"])
    assert res.exit_code == 2, res.output
    name = " ".join(path)
    lines = _stderr_lines(res)
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith(f"slt: error: {name}: No such option: --no-such-option"), lines
    assert lines[0].endswith(f"(see 'slt {name} -h')"), lines  # click may suggest one between
    assert res.stdout == ""


def test_usage_errors_of_groups_are_one_line() -> None:
    for args, text in [
        (["--no-such-option"], "slt: error: No such option: --no-such-option (see 'slt -h')"),
        (["camera", "nosuch"], "slt: error: camera: No such command 'nosuch'."),
    ]:
        res = runner.invoke(app, args)
        assert res.exit_code == 2, res.output
        lines = _stderr_lines(res)
        assert len(lines) == 1, res.stderr
        assert lines[0].startswith(text), lines


DBC = REPO / "superlane_tools" / "data" / "dbc" / "slt_vehicle.dbc"
BAD_VALUES: dict[str, list[str]] = {
    "camera calibrate": ["--board", "9by6"],
    "camera show": ["nosuchcam"],
    "cat": ["-n", "0"],
    "reprocess": ["--camera", "nosuchcam"],
    "corridor": ["--camera", "nosuchcam"],
    "segment": ["--camera", "nosuchcam"],
    "lanes fit": ["--camera", "nosuchcam"],
    "lanes export-kitti": ["--camera", "nosuchcam"],
    "eval kitti": ["--category", "nosuch"],
    "eval caltech": ["--clip", "nosuch"],
    # checked by the command itself, once its inputs are there
    "dbc show": ["--message", "nosuch", str(DBC)],
    "filter": ["--topics", "(", str(SAMPLE), "-o", "unused.mcap"],
    "recover": ["-o", str(SAMPLE), str(SAMPLE)],  # an existing output is refused
    "tables availability": ["--by", "nosuch", str(REPO)],
    "history": ["--margin", "x", str(REPO)],
}
"""Bad values the issue reports, and those of commands without a number option (the others get
"x" for their first number option)."""
NO_VALUES = {"camera list", "info", "tables curvature", "tables paper"}
"""Commands without an option that takes a value (the unknown-option test covers them)."""


def _bad_value(path: tuple[str, ...], command: Any) -> list[str] | None:
    name = " ".join(path)
    if name in BAD_VALUES:
        return BAD_VALUES[name]
    for option in _options(command):
        if option.metavar in ("INTEGER", "NUMBER"):
            return [option.opts[0], "x"]
    return None


@pytest.mark.parametrize(("path", "command"), LEAVES, ids=LEAF_IDS)
def test_bad_value_is_one_line_exit_2(path: tuple[str, ...], command: Any) -> None:
    bad = _bad_value(path, command)
    if bad is None:
        assert " ".join(path) in NO_VALUES, f"slt {' '.join(path)}: add a case to BAD_VALUES"
        return
    res = runner.invoke(app, [*path, *bad])  # before the arguments: click checks it first
    assert res.exit_code == 2, res.output
    lines = _stderr_lines(res)
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("slt: error: "), lines
    assert bad[0] in lines[0] or bad[1] in lines[0], lines  # names the option or the value
    assert res.stdout == ""


T0 = 1_700_000_000_000_000_000


def _truncated_mcap(tmp_path: Path) -> Path:
    from superlane_tools.recording import messages as m
    from superlane_tools.recording.writers import open_writer

    full = tmp_path / "full.mcap"
    with open_writer(full, "mcap", chunk_size=4096) as writer:
        writer.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(400):
            t = T0 + i * 100_000_000
            writer.write("/fix", t, m.navsatfix(t, "gnss", 48.0, 11.0, 500.0))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full.read_bytes()[: full.stat().st_size // 2])
    return cut


def _images_with_a_broken_one(tmp_path: Path) -> Path:
    import cv2
    import numpy as np

    folder = tmp_path / "images"
    folder.mkdir()
    img = np.random.default_rng(1).integers(60, 120, (90, 160, 3), dtype=np.uint8)
    cv2.imwrite(str(folder / "a.png"), img)
    (folder / "broken.png").write_bytes(b"not a png")
    return folder


def _culane_without_one_prediction(tmp_path: Path) -> list[str]:
    import numpy as np

    from superlane_tools.evaluation.culane import format_lines

    lane = np.stack([np.full(20, 300.0), np.linspace(200.0, 580.0, 20)], 1)
    for root, names in ((tmp_path / "gt", ("1", "2")), (tmp_path / "pred", ("1",))):
        (root / "d").mkdir(parents=True)
        for name in names:
            (root / "d" / f"{name}.lines.txt").write_text(format_lines([lane]))
    return [str(tmp_path / "pred"), str(tmp_path / "gt")]


def _batch_with_a_corrupt_recording(tmp_path: Path, request: pytest.FixtureRequest) -> list[str]:
    recs = request.getfixturevalue("make_drives")(1, 1)  # into tmp_path/recs
    config = tmp_path / "c.toml"
    config.write_text('frame_format = "none"\n')
    args = [str(recs[0].parent), "--job", "extract", "--config", str(config), "--workers", "1"]
    return [*args, "-o", str(tmp_path / "out")]


def _udacity_chessboards(tmp_path: Path, request: pytest.FixtureRequest) -> list[str]:
    folder = request.getfixturevalue("realdata") / "udacity" / "advanced_lane_lines"
    return [str(folder / "camera_cal"), "-o", str(tmp_path / "cam.yaml")]


PARTIAL: dict[str, Any] = {
    "info": lambda tmp, _: [str(_truncated_mcap(tmp))],
    "cat": lambda tmp, _: [str(_truncated_mcap(tmp))],
    "extract": lambda tmp, _: [str(_bad_checksum_log(tmp)), "-o", str(tmp / "out")],
    "convert": lambda tmp, _: [str(_bad_checksum_log(tmp)), "-o", str(tmp / "out.mcap")],
    "segment": lambda tmp, _: [str(_images_with_a_broken_one(tmp)), "-o", str(tmp / "out")],
    "eval culane": lambda tmp, _: _culane_without_one_prediction(tmp),
    "batch": _batch_with_a_corrupt_recording,
    "camera calibrate": _udacity_chessboards,
    "filter": lambda tmp, _: [str(_truncated_mcap(tmp)), "-o", str(tmp / "f.mcap")],
    "recover": lambda tmp, _: [str(_truncated_mcap(tmp)), "-o", str(tmp / "r.mcap")],
}
"""Builders ``(tmp_path, request) -> arguments`` of a partial input of each command whose
inputs can be partial."""
PARTIAL_ELSEWHERE = {
    "compare": "tests/commands/compare/test_compare.py::test_unmatched_drives_are_listed",
    "mine": "tests/commands/mine/test_mine.py::test_mining_without_the_recording_is_partial",
    "reprocess": "tests/cli/test_cli_reprocess.py (a truncated drive, slow)",
    "corridor": "tests/cli/test_cli_corridor_train.py (needs a trained model, slow)",
    "lanes fit": "tests/cli/test_cli_lanes.py::test_partial_when_a_png_is_unreadable",
    "eval kitti": "same frames-without-a-prediction report as eval culane",
    "eval tusimple": "same frames-without-a-prediction report as eval culane",
    "eval caltech": "same frames-without-a-prediction report as eval culane",
}
"""Commands with partial inputs whose case is too slow here, or is the same code as one here."""
NOT_PARTIAL = {
    "camera list": "no input",
    "camera show": "one profile: it loads or not",
    "camera from-kitti": "one calibration file: it parses or not",
    "camera estimate": "frames without lanes are not data lost (counted in the profile)",
    "dbc show": "DBC repairs are notes; a DBC that does not load is an error",
    "eval attributes": "one record per frame: a missing frame is scored, not skipped",
    "history": "reads the history dataset whole; an unreadable file is an error",
    "lanes export-kitti": "exports what the lanes table holds",
    "lanes export-tusimple": "exports what the lanes table holds",
    "simulate dataset": "no input",
    "tables availability": "aggregates the runs given",
    "tables curvature": "aggregates the runs given",
    "tables paper": "aggregates the records given",
    "train": "training data is read whole; a bad sample is an error",
}
SLOW_PARTIAL = {"batch", "camera calibrate"}


def test_every_command_has_a_partial_case_or_a_reason() -> None:
    names = set(LEAF_IDS)
    covered = set(PARTIAL) | set(PARTIAL_ELSEWHERE) | set(NOT_PARTIAL)
    assert names == covered, (names - covered, covered - names)


def _partial_params() -> list[Any]:
    marks: dict[str, list[Any]] = {}
    for name in SLOW_PARTIAL:
        marks.setdefault(name, []).append(pytest.mark.slow)
    return [pytest.param(name, marks=marks.get(name, []), id=name) for name in PARTIAL]


@pytest.mark.parametrize("name", _partial_params())
def test_partial_input_exits_3_with_one_skipped_line_per_kind(
    name: str, tmp_path: Path, request: pytest.FixtureRequest
) -> None:
    res = runner.invoke(app, [*name.split(), *PARTIAL[name](tmp_path, request)])
    assert res.exit_code == 3, res.output
    skipped = [line for line in _stderr_lines(res) if line.startswith("slt: skipped: ")]
    assert skipped, res.stderr
    kinds = [line.removeprefix("slt: skipped: ").split(": ")[0] for line in skipped]
    assert len(kinds) == len(set(kinds)), skipped  # one line per kind
    assert "slt: skipped:" not in res.stdout


# Issue 35: every usage error names its command, every bad option value exits 2.

WITH_O = [(path, cmd) for path, cmd in LEAVES if any("-o" in p.opts for p in _options(cmd))]


@pytest.mark.parametrize(("path", "command"), WITH_O, ids=[" ".join(p) for p, _ in WITH_O])
def test_o_without_a_value_names_the_command(path: tuple[str, ...], command: Any) -> None:
    res = runner.invoke(app, [*path, "-o"])
    assert res.exit_code == 2, res.output
    lines = _stderr_lines(res)
    name = " ".join(path)
    assert lines == [f"slt: error: {name}: Option '-o' requires an argument. (see 'slt {name} -h')"]


@pytest.mark.parametrize(
    ("path", "command"),
    _with_option("--model"),
    ids=[" ".join(p) for p, _ in _with_option("--model")],
)
def test_unknown_model_is_a_usage_error(path: tuple[str, ...], command: Any) -> None:
    res = runner.invoke(app, [*path, "--model", "nosuch_model"])
    assert res.exit_code == 2, res.output
    lines = _stderr_lines(res)
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith(f"slt: error: {' '.join(path)}: Invalid value for '--model'")
    assert "not a bundled model" in lines[0]


def test_a_usage_error_raised_by_a_command_names_it(tmp_path: Path) -> None:
    res = runner.invoke(app, ["convert", str(tmp_path / "a.nmea"), "-o", str(tmp_path / "o.mcap"),
                              "--kind", "a.nmea=nope"])  # fmt: skip
    assert res.exit_code == 2, res.output
    assert _stderr_lines(res) == ["slt: error: convert: --kind must be one of video, nmea, gpx, "
                                  "can, csv, got 'nope'"]  # fmt: skip
