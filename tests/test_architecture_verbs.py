"""One verb per layer (issue 34 item 5): reprocess, compare and mine are short and loop-free.

Each orchestration enters the layer below through that layer's verb (``drive.reprocess_pass``,
``fleet.load``, ``fleet.label_set``) and holds no loop over drives or frames of its own, and no
read of a recording or a table: the walk goes down once.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "superlane_tools"

ORCHESTRATIONS = {
    "commands/reprocess/run.py": ("reprocess", "superlane_tools.drive.reprocess_pass"),
    "commands/compare/run.py": ("compare_runs", "superlane_tools.fleet"),
    "commands/mine/run.py": ("mine_runs", "superlane_tools.fleet.label_set"),
}
MAX_BODY_LINES = 40
"""Lines of a command's body (its docstring aside): "reads as about 40 lines"."""
READERS = {"read_tables", "read_parquet", "find_drives", "run_frames", "read_lanes"}
"""Calls that read a fleet's tables or a recording's messages: the layer's, never the command's."""


def _function(path: Path, name: str) -> ast.FunctionDef:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name]
    assert found, f"{path}: no function {name}"
    return found[0]


def _body_lines(fn: ast.FunctionDef) -> int:
    body = fn.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]  # the docstring
    return (body[-1].end_lineno or 0) - body[0].lineno + 1


@pytest.mark.parametrize("rel", sorted(ORCHESTRATIONS))
def test_orchestration_is_short_and_loop_free(rel: str) -> None:
    name, _verb = ORCHESTRATIONS[rel]
    fn = _function(PACKAGE / rel, name)
    assert _body_lines(fn) <= MAX_BODY_LINES, f"{rel}: {name} is {_body_lines(fn)} lines"
    loops = [n for n in ast.walk(fn) if isinstance(n, ast.For | ast.While)]
    assert not loops, f"{rel}: {name} loops (line {loops[0].lineno if loops else 0})"
    calls = {
        n.func.id if isinstance(n.func, ast.Name) else getattr(n.func, "attr", "")
        for n in ast.walk(fn)
        if isinstance(n, ast.Call)
    }
    assert not calls & READERS, f"{rel}: {name} reads itself: {sorted(calls & READERS)}"


@pytest.mark.parametrize("rel", sorted(ORCHESTRATIONS))
def test_orchestration_imports_its_layers_verb(rel: str) -> None:
    _name, verb = ORCHESTRATIONS[rel]
    tree = ast.parse((PACKAGE / rel).read_text(encoding="utf-8"))
    modules = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert verb in modules, f"{rel} does not import {verb}"
