"""Reading the evaluators' text inputs with one error message shape."""

from __future__ import annotations

import os
from pathlib import Path

from superlane_tools.evaluation.errors import EvaluationError


def read_text(path: str | os.PathLike[str], what: str = "") -> str:
    """Return a UTF-8 text file's content.

    Raises:
        EvaluationError: ``cannot read <what> <path>: <reason>`` if it cannot be read.
    """
    file = Path(path)
    try:
        return file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        reason = err.strerror if isinstance(err, OSError) else "not UTF-8 text"
        label = f"{what} " if what else ""
        raise EvaluationError(f"cannot read {label}{file}: {reason}") from err
