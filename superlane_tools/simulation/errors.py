"""Errors of the drive simulator."""

from superlane_tools.errors import SltError, UsageError


class SimulationError(SltError):
    """A simulated drive could not be produced (writer failure, renderer missing...)."""


class ScenarioError(UsageError):
    """An impossible request: unknown scenario, impossible geometry or image size."""
