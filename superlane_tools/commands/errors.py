"""Errors of the pipeline layer."""

from superlane_tools.errors import SltError


class PipelineError(SltError):
    """A pipeline could not produce its outputs (nothing usable in the input, bad setup)."""
