"""``slt extract``'s entry: the options as typed, the settings parsed, the extraction run."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.commands.options import (
    OutputGuard,
    ProgressOpener,
    parse_origin,
    parse_time_range,
)

if TYPE_CHECKING:
    from superlane_tools.can import LoadedDbc
    from superlane_tools.commands.extract.config import ExtractConfig, ExtractResult


@dataclass(frozen=True)
class ExtractOptions:
    """What ``slt extract`` was asked, as typed (see its options)."""

    recording: Path
    out: Path
    topics: list[str] = field(default_factory=list)
    start: str | None = None
    end: str | None = None
    dbc: list[Path] = field(default_factory=list)
    frames: str = "jpg"
    every: int = 1
    origin: str | None = None
    config: Path | None = None
    verbose: bool = False
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def settings(options: ExtractOptions) -> ExtractConfig:
    """Parse the options into what to extract (the stream config file, times, origin).

    Raises:
        ConfigError: If the stream config file is bad.
        UsageError: If a time, the origin, the frame format or ``--every`` is bad.
    """
    from superlane_tools.commands.extract.config import ExtractConfig
    from superlane_tools.recording import load_stream_config

    o = options
    streams = load_stream_config(o.config) if o.config is not None else {}
    start_s, start_ns = parse_time_range(o.start, "--start")
    end_s, end_ns = parse_time_range(o.end, "--end")
    return ExtractConfig(
        topics=tuple(o.topics),
        streams=streams,
        start_s=start_s,
        end_s=end_s,
        start_ns=start_ns,
        end_ns=end_ns,
        dbc_paths=tuple(o.dbc),
        frame_format=o.frames.lower(),
        every=o.every,
        origin=parse_origin(o.origin),
    )


def dbc_lines(name: str, loaded: LoadedDbc, verbose: bool) -> list[str]:
    """Return the notes on one loaded DBC: how many repairs (with ``verbose``, each one)."""
    repairs = getattr(loaded, "repairs", [])
    hint = " (--verbose or `slt dbc show` lists them)" if repairs and not verbose else ""
    lines = [f"dbc {name}: loaded with {len(repairs)} repair(s){hint}"]
    return lines + [f"dbc {name}: {line}" for line in (repairs if verbose else [])]


def _tell_dbc(note: Callable[[str], None], verbose: bool, name: str, loaded: LoadedDbc) -> None:
    for line in dbc_lines(name, loaded, verbose):
        note(line)


def run(
    options: ExtractOptions, progress: ProgressOpener, note: Callable[[str], None]
) -> ExtractResult:
    """Parse the settings, then extract the recording into its output folder.

    Args:
        options: What to extract, and where.
        progress: Opens the progress display (messages read).
        note: Prints one note line (what each DBC needed repaired, as it loads).
    """
    from superlane_tools.commands.extract.run import extract

    o = options
    config = settings(o)
    with o.output_guard, progress() as bar:
        return extract(
            o.recording,
            o.out,
            config,
            command=o.command,
            progress=bar.update,
            on_dbc=partial(_tell_dbc, note, o.verbose),
        )
