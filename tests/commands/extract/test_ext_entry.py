"""``slt extract``'s entry: options parsed in order, the output guard, progress and DBC notes."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from superlane_tools.commands.extract.entry import ExtractOptions, run, settings
from superlane_tools.errors import UsageError
from superlane_tools.recording.messages import can_frame, navsatfix
from superlane_tools.recording.writers import open_writer

T0 = 1_700_000_000_000_000_000
MS = 1_000_000
DBC = (
    'VERSION ""\nBU_: A\nBO_ 256 M: 8 A\n'
    ' SG_ S1 : -1|8@1+ (1,0) [0|0] "" A\n'  # impossible: dropped, one repair
    ' SG_ S2 : 0|8@1+ (1,0) [0|0] "" A\n'
)


def _drive(path: Path) -> Path:
    """Write 20 CAN frames and 20 fixes at 10 Hz (no images)."""
    with open_writer(path, "mcap") as w:
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(20):
            t = T0 + i * 100 * MS
            w.write("/can", t, can_frame(t, 256, bytes([i, 0])))
            w.write("/fix", t, navsatfix(t, "gps", 48.0 + i * 1e-5, 11.0, 500.0, status=2))
    return path


class _Bar:
    """A progress display of this test: records what it is told."""

    def __init__(self, events: list[str]) -> None:
        self.events = events
        self.updates: list[tuple[int, int | None]] = []

    def update(
        self, done: int, total: int | None = None, note: str = "", label: str | None = None
    ) -> None:
        self.updates.append((done, total))

    def phase(self, label: str, note: str = "") -> None:
        self.events.append(f"phase {label}")


def test_settings_parse_times_origin_and_the_first_bad_option_wins(tmp_path: Path) -> None:
    o = ExtractOptions(tmp_path / "x.mcap", tmp_path / "out", ["/a"], "1.5", "3", frames="PNG")
    config = settings(o)
    assert (config.start_s, config.end_s, config.start_ns, config.end_ns) == (1.5, 3.0, None, None)
    assert (config.topics, config.frame_format, config.origin) == (("/a",), "png", None)
    absolute = settings(ExtractOptions(tmp_path / "x", tmp_path / "o", start=str(T0)))
    assert (absolute.start_s, absolute.start_ns) == (None, T0)
    assert settings(ExtractOptions(tmp_path / "x", tmp_path / "o", origin="48,11")).origin
    with pytest.raises(UsageError, match="--start"):
        settings(ExtractOptions(tmp_path / "x", tmp_path / "o", start="soon", origin="north"))
    with pytest.raises(UsageError, match="--origin"):
        settings(ExtractOptions(tmp_path / "x", tmp_path / "o", origin="north"))
    with pytest.raises(UsageError, match="after --start"):
        settings(ExtractOptions(tmp_path / "x", tmp_path / "o", start="3", end="2"))


@pytest.mark.parametrize("verbose", [False, True])
def test_run_writes_inside_the_guard_with_progress_and_dbc_notes(
    tmp_path: Path, verbose: bool
) -> None:
    recording = _drive(tmp_path / "drive.mcap")
    dbc = tmp_path / "car.dbc"
    dbc.write_text(DBC, encoding="utf-8")
    out = tmp_path / "out"
    events: list[str] = []
    bar = _Bar(events)

    @contextmanager
    def guard() -> Iterator[None]:
        events.append("guard")
        yield
        events.append(f"guarded {sorted(p.name for p in out.iterdir())}")

    @contextmanager
    def opener() -> Iterator[_Bar]:
        events.append("progress")
        yield bar

    notes: list[str] = []
    options = ExtractOptions(
        recording, out, dbc=[dbc], verbose=verbose, command="slt extract", output_guard=guard()
    )
    result = run(options, opener, notes.append)
    tables = ["can_raw.parquet", "can_signals.parquet", "rtk.parquet"]
    assert events == ["guard", "progress", f"guarded {tables}"]
    assert sorted(p.name for p in result.outputs) == tables
    assert dict(result.counts) == {
        "frames": 0,
        "can_frames": 20,
        "can_signals": 20,
        "gnss_fixes": 20,
    }
    assert bar.updates[-1] == (40, 40)
    assert notes[0] == (
        "dbc car.dbc: loaded with 1 repair(s)"
        + ("" if verbose else " (--verbose or `slt dbc show` lists them)")
    )
    assert len(notes) == (2 if verbose else 1)
    if verbose:
        assert notes[1].startswith("dbc car.dbc: dropped signal S1 of message M")


def test_a_bad_option_stops_before_the_guard(tmp_path: Path) -> None:
    entered: list[str] = []

    @contextmanager
    def guard() -> Iterator[None]:
        entered.append("guard")
        yield

    options = ExtractOptions(tmp_path / "x.mcap", tmp_path / "out", every=0, output_guard=guard())
    with pytest.raises(UsageError, match="--every"):
        run(options, lambda: pytest.fail("no progress for bad options"), print)
    assert entered == []
