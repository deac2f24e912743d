"""Errors of the recording layer: unreadable or unrecognised recordings."""

from __future__ import annotations

from superlane_tools.errors import ExitCode, SltError


class RecordingError(SltError):
    """A path is not a recording, or a recording cannot be opened or written."""

    exit_code = ExitCode.ERROR
