"""What ``cli/`` asks the layers while it parses: option checks, hints, the output file moves.

Every function here is small and raises the layer's own error; the cli turns it into a usage
message. Heavy modules are imported inside the functions, so ``slt --help`` stays light.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from superlane_tools.records import Skipped


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
