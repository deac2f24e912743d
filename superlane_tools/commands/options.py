"""What ``cli/`` asks the layers while it parses: option checks, hints, the output file moves.

Every function here is small and raises the layer's own error; the cli turns it into a usage
message. Heavy modules are imported inside the functions, so ``slt --help`` stays light.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from superlane_tools.errors import UsageError
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from superlane_tools.geo import GeodeticOrigin


class ProgressBar(Protocol):
    """The cli's progress display of one long step, as a command reports to it."""

    def update(
        self, done: int, total: int | None = None, note: str = "", label: str | None = None
    ) -> None:
        """Set the items done (and the total, a short note, the label)."""

    def phase(self, label: str, note: str = "") -> None:
        """Start a phase: show its label (and a note), no count until it reports one."""


ProgressOpener = Callable[[], AbstractContextManager[ProgressBar]]
"""Opens the progress display of a command's long step (the cli's ``progress(...)``)."""

OutputGuard = AbstractContextManager[Any]
"""Entered around the writing of a command's output, after its options are checked: the cli's
one policy for an existing output (``cli/_outputs.py``: refuse, or replace with
``--overwrite``)."""


def check_camera(value: str) -> None:
    """Load the camera profile or YAML ``value`` once; raise its ``SltError`` if it fails."""
    from superlane_tools.camera import load_camera

    load_camera(value)


def check_model(value: str) -> None:
    """Resolve the model ``value`` (a file or a bundled name); raise its ``SltError`` if none."""
    from superlane_tools.scene.onnx_backend import resolve_model

    resolve_model(value)


def dbc_spec_path(value: str) -> Path:
    """Return the file of a ``[BUS=]FILE`` DBC spec; raise ``SltError`` on a malformed one."""
    from superlane_tools.can.buses import parse_dbc_spec

    return parse_dbc_spec(value).path


def recover_hint(where: Path, skipped: Sequence[Skipped]) -> str | None:
    """Return the note naming ``slt recover`` for a damaged recording, or None."""
    from superlane_tools.reporting.drive_notes import recover_hint as hint

    return hint(where, skipped)


def settle_replaced(out: Path) -> None:
    """Finish what a killed ``--overwrite`` left: the old output back, or gone."""
    from superlane_tools.reporting.atomic import settle_replaced as settle

    settle(out)


@contextmanager
def replacing(out: Path) -> Iterator[None]:
    """Set ``out`` aside while the block writes the new one; put it back if the block fails."""
    from superlane_tools.reporting.atomic import replacing as replace

    with replace(out):
        yield


def parse_origin(text: str | None) -> GeodeticOrigin | None:
    """Parse an ``--origin LAT,LON[,ALT]`` value; a malformed one is a ``UsageError``."""
    from superlane_tools.geo import GeoError
    from superlane_tools.geo import parse_origin as parse

    if text is None:
        return None
    try:
        return parse(text)
    except GeoError as err:
        raise UsageError(f"--origin: {err}") from err


def parse_time_range(text: str | None, option: str) -> tuple[float | None, int | None]:
    """Parse a ``--start``/``--end`` value: (seconds after the first message, absolute ns)."""
    from superlane_tools.recording.times import parse_time

    if text is None:
        return None, None
    spec = parse_time(text, option)
    return (None, spec.ns) if spec.absolute else (spec.ns / 1e9, None)
