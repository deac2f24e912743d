"""Errors of the batch engine (a part of the pipeline layer)."""

from superlane_tools.commands.errors import PipelineError


class BatchError(PipelineError):
    """The batch as a whole cannot run: output root unwritable, locked, engine unavailable."""


class EngineUnavailableError(BatchError):
    """The requested engine needs an optional extra that is not installed."""
