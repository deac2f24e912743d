"""Sizes (issue 34 item 6): few long functions, no module over 600 lines.

A function over :data:`LONG_LINES` lines (``def`` to its last line, docstring included) is a
function doing several things; the package allows at most :data:`MAX_LONG` of them (numba
kernels and the like, whose state would cost speed to split). A module over
:data:`MAX_MODULE_LINES` lines holds more than one thing.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "superlane_tools"
LONG_LINES = 80
MAX_LONG = 12
MAX_MODULE_LINES = 600


def _long_functions() -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > LONG_LINES:
                    found.append(f"{path.relative_to(PACKAGE)}:{node.name} ({lines} lines)")
    return found


def test_at_most_twelve_long_functions() -> None:
    long = _long_functions()
    assert len(long) <= MAX_LONG, f"{len(long)} functions over {LONG_LINES} lines:\n" + "\n".join(
        long
    )


def test_no_module_over_600_lines() -> None:
    big = {
        str(p.relative_to(PACKAGE)): n
        for p in PACKAGE.rglob("*.py")
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    }
    assert not big, big
