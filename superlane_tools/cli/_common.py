"""Shared CLI plumbing: error-to-exit-code mapping, console, progress bars."""

from __future__ import annotations

import os
import shlex
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import NoReturn

import click
import typer
from rich.console import Console

from superlane_tools.errors import ExitCode, SltError
from superlane_tools.records import Skipped

err_console = Console(stderr=True, highlight=False)
console = Console(highlight=False)

EXIT_CODES_HELP = (
    "Exit codes: 0 ok, 1 error (bad input, nothing usable written), 2 usage, "
    "3 partial (outputs written but some input data was lost or skipped)."
)


def fail(message: str, code: ExitCode = ExitCode.ERROR) -> NoReturn:
    """Print one ``slt: error: ...`` line to stderr and exit with ``code``."""
    err_console.print(f"slt: error: {message}", markup=False, soft_wrap=True)
    raise typer.Exit(int(code))


@contextmanager
def cli_errors() -> Iterator[None]:
    """Map ``SltError`` (and stray OS errors on input files) to one line and an exit code."""
    try:
        yield
    except SltError as err:
        fail(str(err), err.exit_code)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
        fail(f"{err.strerror}: {err.filename}", ExitCode.ERROR)


def report_skipped(skipped: Sequence[Skipped]) -> ExitCode:
    """Print what was skipped or lost, one line each; return PARTIAL if anything was."""
    for item in skipped:
        count = f" ({item.n_items})" if item.n_items else ""
        err_console.print(f"slt: skipped: {item.what}{count}: {item.detail}", markup=False)
    return ExitCode.PARTIAL if skipped else ExitCode.OK


def debug_enabled() -> bool:
    """Return True when ``SLT_DEBUG`` asks for full tracebacks on internal errors."""
    return os.environ.get("SLT_DEBUG", "") not in {"", "0"}


def exit_with(code: ExitCode) -> None:
    """Exit the command with ``code`` unless it is OK."""
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


def _current_context() -> click.Context | None:
    """Return the active click context; recent typer versions run on a vendored click copy."""
    vendored = getattr(getattr(typer, "_click", None), "globals", None)
    getter = getattr(vendored, "get_current_context", None) or click.get_current_context
    ctx: click.Context | None = getter(silent=True)
    return ctx


def command_line() -> str:
    """Return the command line, for provenance metadata.

    As typed when running as the ``slt`` program; otherwise (the CLI invoked in-process, e.g.
    by a test runner or another tool) rebuilt from the click context's command path and
    parameters, since ``sys.argv`` then belongs to the host program.
    """
    if sys.argv and Path(sys.argv[0]).name == "slt":
        return shlex.join(["slt", *sys.argv[1:]])
    ctx = _current_context()
    if ctx is None:
        return "slt"
    parts = ["slt", *ctx.command_path.split()[1:]]
    for name, value in ctx.params.items():
        if value is None or value is False or value in ((), []):
            continue
        flag = "--" + name.replace("_", "-")
        parts.append(flag if value is True else f"{flag} {shlex.quote(str(value))}")
    return " ".join(parts)
