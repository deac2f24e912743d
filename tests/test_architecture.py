"""Keep the architecture honest: layers import one way only; `slt --help` stays light."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "superlane_tools"

# Lower layers never import higher ones. Equal ranks may import each other only one way
# (checked below by the absence of package cycles).
RANKS = {
    "_version": 0,
    "errors": 0,
    "records": 0,
    "hierarchy": 0,
    "geo": 1,
    "camera": 1,
    "lanes": 1,
    "evaluation": 1,
    "corridor": 1,
    "recording": 2,
    "can": 2,
    "reporting": 2,
    "scene": 2,
    "models": 2,
    "simulation": 3,
    "training": 3,
    "pipeline": 4,
    "cli": 5,
    "__init__": 6,
    "__main__": 6,
}


def _unit(path: Path) -> str:
    rel = path.relative_to(PACKAGE)
    return rel.parts[0].removesuffix(".py")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "superlane_tools" and len(parts) > 1:
                found.add(parts[1])
    return found


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        unit = _unit(path)
        graph.setdefault(unit, set()).update(_imports(path) - {unit})
    return graph


def test_every_unit_has_a_rank() -> None:
    assert set(_graph()) <= set(RANKS), set(_graph()) - set(RANKS)


def test_layers_import_downwards_only() -> None:
    bad = [
        f"{unit} (rank {RANKS[unit]}) imports {dep} (rank {RANKS.get(dep)})"
        for unit, deps in _graph().items()
        for dep in deps
        if RANKS.get(dep, 99) > RANKS[unit]
    ]
    assert not bad, bad


def test_no_package_cycles() -> None:
    graph = _graph()
    state: dict[str, int] = {}

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for dep in graph.get(node, ()):
            if state.get(dep) == 1:
                pytest.fail(f"import cycle: {' -> '.join([*stack, node, dep])}")
            if dep not in state:
                visit(dep, [*stack, node])
        state[node] = 2

    for node in graph:
        if node not in state:
            visit(node, [])


HEAVY = ("onnxruntime", "cv2", "torch", "matplotlib", "ray")


@pytest.mark.parametrize(
    "argv",
    [
        ["--help"],
        ["info", "--help"],
        ["extract", "--help"],
        ["simulate", "--help"],
        ["lanes", "--help"],
        ["camera", "--help"],
        ["eval", "--help"],
        ["segment", "--help"],
        ["reprocess", "--help"],
        ["tables", "--help"],
    ],
)
def test_help_does_not_import_heavy_modules(argv: list[str]) -> None:
    code = (
        "import sys\n"
        f"sys.argv = ['slt', *{argv!r}]\n"
        "from superlane_tools.cli.app import main\n"
        "try:\n    main()\nexcept SystemExit as e:\n    assert e.code in (0, None), e.code\n"
        f"heavy = [m for m in {HEAVY!r} if m in sys.modules]\n"
        "print('HEAVY', heavy)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    ).stdout
    assert "HEAVY []" in out, out
