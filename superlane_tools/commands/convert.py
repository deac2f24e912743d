"""`slt convert`: a dashcam video and GNSS/CAN/signal logs into one MCAP recording."""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.errors import UsageError

if TYPE_CHECKING:
    from superlane_tools.recording.convert import ConvertResult

KINDS = ("video", "nmea", "gpx", "can", "csv")
"""What an input file may hold (``--kind FILE=KIND``)."""


@dataclass(frozen=True)
class ConvertParams:
    """What ``slt convert`` was asked.

    Attributes:
        inputs: The input files.
        out: The output ``.mcap`` file.
        offsets: ``FILE=SECONDS`` values of ``--offset``.
        kinds: ``FILE=KIND`` values of ``--kind``.
        video_start: Time of the first video frame (``parse_time`` syntax), or None.
        fps: Frame rate for the frame times, or None (the container's).
        camera: Camera profile or YAML of the video, or None.
        command: The command line, for the provenance.
        output_guard: Entered around the writing, after the options are checked (the cli's
            policy for an existing output).
    """

    inputs: list[Path]
    out: Path
    offsets: list[str] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    video_start: str | None = None
    fps: float | None = None
    camera: str | None = None
    command: str = ""
    output_guard: AbstractContextManager[object] = field(default_factory=nullcontext)


def _per_file(values: list[str], option: str) -> dict[str, str]:
    """Parse repeated ``NAME=VALUE`` options (NAME: a file name or path given as INPUT)."""
    out: dict[str, str] = {}
    for value in values:
        name, sep, rest = value.partition("=")
        if not sep or not name or not rest:
            raise UsageError(f"{option} takes FILE=VALUE, got {value!r}")
        out[name] = rest
    return out


def run(params: ConvertParams) -> ConvertResult:
    """Check the per-file options, then convert the inputs into one MCAP file.

    Raises:
        UsageError: A malformed ``--offset`` or ``--kind``, or one naming no input.
    """
    from superlane_tools.recording.convert import ConvertConfig, ConvertInput, convert

    offsets = _per_file(params.offsets, "--offset")
    kinds = _per_file(params.kinds, "--kind")
    known = {p.name for p in params.inputs} | {str(p) for p in params.inputs}
    for name in (*offsets, *kinds):
        if name not in known:
            raise UsageError(f"{name} is not one of the INPUT files")
    items = []
    for path in params.inputs:
        k = kinds.get(str(path), kinds.get(path.name))
        if k is not None and k not in KINDS:
            raise UsageError(f"--kind must be one of {', '.join(KINDS)}, got {k!r}")
        text = offsets.get(str(path), offsets.get(path.name, "0"))
        try:
            seconds = float(text)
        except ValueError as err:
            raise UsageError(f"--offset {path.name}: {text!r} is not seconds") from err
        items.append(ConvertInput(path, k, seconds))  # type: ignore[arg-type]
    config = ConvertConfig(params.video_start, params.fps, camera=params.camera)
    with params.output_guard:
        return convert(items, params.out, config, command=params.command)
