"""The one policy for existing outputs, shared by every command that writes one (README)."""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import typer

from superlane_tools.cli._common import cli_errors, fail
from superlane_tools.errors import ExitCode

OVERWRITE_HELP = "Replace an existing output (without it, an existing output is refused: exit 2)."


def overwrite_option() -> Any:
    """Return the shared ``--overwrite`` option of every command that writes an output."""
    return typer.Option("--overwrite", help=OVERWRITE_HELP)


def _holds(folder: Path, path: Path) -> bool:
    """Return True when ``path`` is ``folder`` or lies inside it (both resolved)."""
    try:
        inner, outer = path.resolve(), folder.resolve()
    except OSError:
        return False
    return inner == outer or outer in inner.parents


def output_exists(out: Path | None) -> bool:
    """Return True when ``out`` is an existing output: a file (or link), or a non-empty folder.

    An empty folder holds nothing to lose or to leave stale: it is written into.
    """
    if out is None or not os.path.lexists(out):
        return False
    if out.is_dir() and not out.is_symlink():
        try:
            return any(out.iterdir())
        except OSError:
            return True
    return True


def check_new_output(out: Path | None, overwrite: bool, inputs: Sequence[Path] = ()) -> None:
    """Refuse an existing output without ``--overwrite`` (exit 2), before any work starts.

    Also refuses, whatever ``--overwrite`` says, an output that is or holds one of the
    ``inputs`` or the working folder. See :func:`new_output`.
    """
    if out is None:
        return
    from superlane_tools.commands.options import settle_replaced

    settle_replaced(out)  # what a killed --overwrite left: the old output back, or gone
    if not output_exists(out):
        return
    for path in (*inputs, Path.cwd()):  # first: --overwrite would not help
        if _holds(out, path):
            what = "the working folder" if path == Path.cwd() else f"the input {path}"
            fail(f"--out {out} holds {what}; not replacing it", ExitCode.USAGE)
    if not overwrite:
        fail(f"{out} exists; pass --overwrite to replace it", ExitCode.USAGE)


@contextmanager
def new_output(
    out: Path | None,
    overwrite: bool,
    inputs: Sequence[Path] = (),
    *,
    replaces: bool = False,
) -> Iterator[None]:
    """Apply the one policy for existing outputs around the block that writes ``out``.

    An output that does not exist (or an empty folder) is written. An existing one is a usage
    error (exit 2, nothing written) unless ``--overwrite`` (:func:`check_new_output`): then the
    old output is set aside, the block writes the new one, and the old one is removed (put back
    when the block fails), so nothing stale survives
    (:func:`~superlane_tools.reporting.atomic.replacing`).

    Args:
        out: The output file or folder (None: the command prints instead).
        overwrite: The command's ``--overwrite``.
        inputs: The command's input paths (never replaced).
        replaces: The command's writer replaces the old output itself, atomically (a run folder
            published by one rename, a file written by the atomic writer): only the refusal
            applies.
    """
    check_new_output(out, overwrite, inputs)
    if out is None or replaces or not output_exists(out):
        yield
        return
    from superlane_tools.commands.options import replacing

    with cli_errors(), replacing(out):
        yield
