"""Root of the error hierarchy: every error the toolkit raises on purpose is an ``SltError``.

Each layer defines its own subclass in its own ``errors.py`` (``recording.errors.RecordingError``,
``camera.errors.CameraError``, ...) and converts outside exceptions at its boundary with
``raise LayerError(msg) from err``. The CLI maps ``SltError`` to a one-line message and an exit
code; anything else is a bug.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Literal

MessageKind = Literal["error", "skipped", "note", "progress"]
"""The kinds of message a command writes to stderr, each line ``slt: KIND: text``."""


class ExitCode(IntEnum):
    """Documented process exit codes of the ``slt`` command."""

    OK = 0
    """Everything requested was done."""
    ERROR = 1
    """Nothing usable was produced: bad input file, failed stage, internal error."""
    USAGE = 2
    """Wrong command line: unknown option, bad value, missing argument."""
    PARTIAL = 3
    """Outputs were written, but some input data was lost or skipped (reported)."""
    REGRESSION = 4
    """``slt compare --fail-on-regression``: a gated KPI of the candidate is worse (outputs
    written)."""


def message_line(kind: MessageKind, text: str) -> str:
    """Return the one stderr line of a message: ``slt: KIND: text``, whitespace collapsed.

    Every message of every command and of the layers below (the lane fit's compile note) is
    built here, so a log collector can sort lines by prefix: ``error`` (the command failed or
    refused a value), ``skipped`` (input data lost, one line per kind with a count), ``note``
    (facts worth knowing, nothing lost) and ``progress``.
    """
    return f"slt: {kind}: {' '.join(text.split())}"


class SltError(Exception):
    """Base of all deliberate superlane-tools errors.

    Attributes:
        exit_code: Process exit code the CLI uses for this error.
    """

    exit_code: ExitCode = ExitCode.ERROR


class UsageError(SltError):
    """A request that cannot be satisfied as stated (bad option values, unknown names)."""

    exit_code = ExitCode.USAGE


class ConfigError(UsageError):
    """A configuration file or value is invalid."""
