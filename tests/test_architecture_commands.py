"""One command contract: ``cli/`` parses options, calls ``commands/<command>`` and prints.

The rule is an allow-list, read with ``ast`` from every module of ``superlane_tools/cli``: of
the package it imports only ``superlane_tools.commands.*``, ``errors``, ``records``,
``_version`` and ``cli`` itself; outside the package only the standard library and the CLI's
own libraries (typer, click, rich). Imports under ``if TYPE_CHECKING:`` are exempt (they never
run). Everything above parsing and printing (loops, writers, format knowledge) lives in
``commands/``, so a new command has one obvious place.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CLI = ROOT / "superlane_tools" / "cli"

ALLOWED_OWN = ("commands", "errors", "records", "_version", "cli")
"""What of ``superlane_tools`` the cli may import (the first part after the package name)."""
ALLOWED_OTHER = frozenset(sys.stdlib_module_names) | {"typer", "click", "rich"}
"""Top-level modules outside the package the cli may import: parsing and printing only."""


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _runtime_imports(tree: ast.AST) -> list[tuple[int, str]]:
    """Return ``(line, dotted name)`` of every import that runs, also function-local ones.

    ``from superlane_tools import records`` gives ``superlane_tools.records``.
    """
    found: list[tuple[int, str]] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"line {node.lineno}: relative import"
            module = node.module or ""
            if module == "superlane_tools":
                found.extend((node.lineno, f"{module}.{alias.name}") for alias in node.names)
            else:
                found.append((node.lineno, module))
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def _forbidden(name: str) -> bool:
    parts = name.split(".")
    if parts[0] == "__future__":
        return False
    if parts[0] != "superlane_tools":
        return parts[0] not in ALLOWED_OTHER
    return len(parts) < 2 or parts[1] not in ALLOWED_OWN


def _violations(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [
        f"{path.name}:{line} imports {name}"
        for line, name in _runtime_imports(tree)
        if _forbidden(name)
    ]


@pytest.mark.parametrize("path", sorted(CLI.glob("*.py")), ids=lambda p: p.name)
def test_the_cli_imports_only_commands(path: Path) -> None:
    bad = _violations(path)
    assert not bad, f"cli/ calls a lower layer (move the work into commands/<command>): {bad}"


def test_the_rule_sees_a_broken_import(tmp_path: Path) -> None:
    """The checker itself: a lower layer, a heavy library, a local import all count."""
    module = tmp_path / "bad.py"
    module.write_text(
        "from typing import TYPE_CHECKING\n"
        "import typer\n"
        "from superlane_tools.commands.mine import run\n"
        "from superlane_tools import errors\n"
        "if TYPE_CHECKING:\n"
        "    from superlane_tools.fleet import MineParams\n"
        "def f():\n"
        "    import numpy\n"
        "    from superlane_tools.recording import open_recording\n"
        "    from superlane_tools import fleet\n",
        encoding="utf-8",
    )
    assert _violations(module) == [
        "bad.py:8 imports numpy",
        "bad.py:9 imports superlane_tools.recording",
        "bad.py:10 imports superlane_tools.fleet",
    ]
