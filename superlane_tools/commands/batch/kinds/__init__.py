"""Batch job kinds: what one batch job does to one recording, one module per kind.

The kinds sit above the engine types (:mod:`~superlane_tools.commands.batch.jobs`); the
engines and workers find a kind by its name through :func:`job_kind`.
"""

from __future__ import annotations

import importlib.util

from superlane_tools.commands.batch.jobs import JobKind
from superlane_tools.commands.batch.kinds.extract import EXTRACT
from superlane_tools.commands.batch.kinds.reprocess import REPROCESS
from superlane_tools.errors import UsageError


def reprocess_available() -> bool:
    """Return True when the ``reprocess`` pipeline is part of this installation."""
    try:
        spec = importlib.util.find_spec("superlane_tools.commands.reprocess")
    except ImportError:
        return False
    # A folder without __init__.py (work in progress) is a namespace package: origin None.
    return spec is not None and spec.origin is not None


def default_kind() -> str:
    """Return the default job kind: ``reprocess`` when available, else ``extract``."""
    return "reprocess" if reprocess_available() else "extract"


def job_kind(name: str) -> JobKind:
    """Return the job kind called ``name``.

    Raises:
        UsageError: If the kind is unknown or not available in this installation.
    """
    if name == "extract":
        return EXTRACT
    if name == "reprocess":
        if not reprocess_available():
            raise UsageError("job kind 'reprocess' is not available in this installation")
        return REPROCESS
    raise UsageError(f"unknown job kind {name!r}: use 'reprocess' or 'extract'")
