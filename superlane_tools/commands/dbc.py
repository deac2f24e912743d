"""`slt dbc show`: a DBC file as slt loads it, described for printing."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def show(dbc: Path, message: str | None = None) -> dict[str, Any]:
    """Load ``dbc`` leniently and describe its messages, signals and repairs.

    Args:
        dbc: The DBC file.
        message: Only this message (name or id, e.g. ``0x766``), or every one.

    Returns:
        The description (``messages``, ``repairs``), JSON-ready.
    """
    from superlane_tools.can import load_dbc
    from superlane_tools.can.describe import describe_dbc

    return describe_dbc(load_dbc(dbc), message)
