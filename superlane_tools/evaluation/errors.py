"""Errors of the evaluation layer."""

from superlane_tools.errors import SltError


class EvaluationError(SltError):
    """A prediction or ground-truth file is missing, malformed or does not match the other."""
