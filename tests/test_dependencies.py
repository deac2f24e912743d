"""Declared dependencies are the imported ones.

The imported top-level modules are read from the sources with ``ast`` and mapped to the
distributions that provide them (``importlib.metadata.packages_distributions``), then checked
against ``pyproject.toml``: what the package imports when a module loads must be a core
dependency; what it imports late (inside a function) must be core or in an extra (``train``,
``ray``); what the tests import may also come from ``dev``. Imports under ``TYPE_CHECKING``
serve type hints only and are not run. A new undeclared import fails here, not on a
newcomer's machine (the way ``click`` did once ``typer`` stopped depending on it).
"""

from __future__ import annotations

import ast
import functools
import re
import sys
import tomllib
from collections.abc import Iterator
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "superlane_tools"
OWN = {"superlane_tools", "tests", "conftest"}
EXTRA_SUBPACKAGES = {"train": PACKAGE / "training"}
"""Subpackages loaded only with an extra: they may import that extra when they load."""
RUNTIME_ONLY = {"onnx": "torch.onnx.export needs it at run time; the package never imports it"}
"""Declared distributions the package needs without importing them, and why."""


def _name(requirement: str) -> str:
    """Return the normalized distribution name of a PEP 508 requirement."""
    match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement)
    assert match, requirement
    return re.sub(r"[-_.]+", "-", match.group(1)).lower()


def _declared() -> dict[str, set[str]]:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    groups = {"core": {_name(r) for r in project["dependencies"]}}
    for extra, reqs in project["optional-dependencies"].items():
        groups[extra] = {_name(r) for r in reqs}
    return groups


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST) -> Iterator[tuple[str, bool, int]]:
    """Yield (top-level module, imported at module load, line) for every run-time import."""

    def visit(node: ast.AST, at_load: bool) -> Iterator[tuple[str, bool, int]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for sub in child.orelse:
                    yield from visit(sub, at_load)
                continue
            if isinstance(child, ast.Import):
                for alias in child.names:
                    yield alias.name.split(".")[0], at_load, child.lineno
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                yield child.module.split(".")[0], at_load, child.lineno
            inner = at_load and not isinstance(
                child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda
            )
            yield from visit(child, inner)

    yield from visit(tree, True)


def _third_party(folder: Path) -> dict[str, list[tuple[str, bool]]]:
    """Return third-party module -> [(file:line, imported at load)] for the sources under folder."""
    found: dict[str, list[tuple[str, bool]]] = {}
    local = {p.stem for p in folder.rglob("*.py")}  # helper modules a conftest puts on sys.path
    for path in sorted(folder.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for module, at_load, line in _imports(tree):
            if module in sys.stdlib_module_names or module in OWN or module == "__future__":
                continue
            if folder != PACKAGE and module in local:
                continue
            where = f"{path.relative_to(REPO)}:{line}"
            found.setdefault(module, []).append((where, at_load))
    return found


@functools.cache
def _installed() -> dict[str, list[str]]:
    return packages_distributions()


def _distributions(module: str) -> set[str]:
    return {re.sub(r"[-_.]+", "-", d).lower() for d in _installed().get(module, [])}


def _extra_of(where: str) -> str | None:
    path = REPO / where.rsplit(":", 1)[0]
    return next((e for e, sub in EXTRA_SUBPACKAGES.items() if sub in path.parents), None)


def test_the_scan_sees_real_imports() -> None:
    found = _third_party(PACKAGE)
    assert {"numpy", "typer", "mcap", "cantools", "numba", "torch", "ray"} <= set(found)
    assert "click" not in found, found.get("click")
    # torch loads with the training subpackage only; everywhere else it is imported late
    assert all(_extra_of(where) == "train" for where, at_load in found["torch"] if at_load)
    assert any(not at_load for _, at_load in found["torch"])


def test_package_imports_are_declared() -> None:
    declared = _declared()
    optional = declared["train"] | declared["ray"]
    problems = []
    for module, uses in sorted(_third_party(PACKAGE).items()):
        dists = _distributions(module)
        if not dists:
            problems.append(f"{module}: imported at {uses[0][0]} but no installed distribution")
            continue
        at_load = [
            where
            for where, load in uses
            if load and not dists & declared.get(_extra_of(where) or "core", set())
        ]
        if at_load and not dists & declared["core"]:
            problems.append(
                f"{module} ({'/'.join(sorted(dists))}): imported when {at_load[0]} "
                "loads, so it must be a core dependency"
            )
        elif not dists & (declared["core"] | optional):
            problems.append(
                f"{module} ({'/'.join(sorted(dists))}): imported at {uses[0][0]}, "
                "declared in neither the core dependencies nor the train/ray extras"
            )
    assert not problems, "\n".join(problems)


def test_test_imports_are_declared() -> None:
    declared = _declared()
    everything = set().union(*declared.values())
    problems = [
        f"{module}: imported at {uses[0][0]}, not a declared dependency of any profile"
        for module, uses in sorted(_third_party(REPO / "tests").items())
        if not _distributions(module) & everything
    ]
    assert not problems, "\n".join(problems)


def test_core_dependencies_are_used() -> None:
    """Every core dependency is imported by the package (plugins included by their module)."""
    used: set[str] = set()
    for module in _third_party(PACKAGE):
        used |= _distributions(module)
    unused = _declared()["core"] - used
    assert not unused, f"declared but never imported: {sorted(unused)}"


@pytest.mark.parametrize("extra", ["train", "ray"])
def test_extras_are_used(extra: str) -> None:
    used: set[str] = set()
    for module in _third_party(PACKAGE):
        used |= _distributions(module)
    assert _declared()[extra] - set(RUNTIME_ONLY) <= used, _declared()[extra] - used


LOCKS = {"core": ("core",), "dev": ("core", "dev", "train", "ray")}
"""Lock file in requirements/ -> the dependency groups its install profile resolves."""


def _lock(name: str) -> dict[str, str]:
    pins: dict[str, str] = {}
    for line in (REPO / "requirements" / f"{name}.txt").read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        match = re.fullmatch(r"([A-Za-z0-9][A-Za-z0-9._-]*)==([0-9][^\s;]*)", line.strip())
        assert match, f"requirements/{name}.txt: not an exact pin: {line!r}"
        pins[_name(match.group(1))] = match.group(2)
    return pins


@pytest.mark.parametrize("lock", sorted(LOCKS))
def test_lock_pins_every_declared_dependency_and_no_cuda(lock: str) -> None:
    from packaging.requirements import Requirement
    from packaging.version import Version

    pins = _lock(lock)
    assert not [n for n in pins if n.startswith("nvidia-") or n == "torch"], (
        "torch is installed first as the CPU build (pip install torch==2.13.0); a pinned torch "
        "or nvidia-* wheel would pull CUDA"
    )
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    groups = {"core": project["dependencies"], **project["optional-dependencies"]}
    for group in LOCKS[lock]:
        for text in groups[group]:
            req = Requirement(text)
            name = _name(req.name)
            if name == "torch":
                continue
            assert name in pins, f"requirements/{lock}.txt lacks {name} ({group})"
            assert Version(pins[name]) in req.specifier, f"{name}=={pins[name]} vs {text}"
    if lock == "core":
        assert not set(pins) & {"ray", "pytest", "onnx", "click"}, "core lock holds extras"


def _annotation_nodes(tree: ast.AST) -> set[int]:
    ids: set[int] = set()
    for node in ast.walk(tree):
        annotations: list[ast.expr | None] = []
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            args = node.args
            every = [*args.posonlyargs, *args.args, *args.kwonlyargs, args.vararg, args.kwarg]
            annotations = [a.annotation for a in every if a is not None]
            annotations.append(node.returns)
        elif isinstance(node, ast.AnnAssign):
            annotations = [node.annotation]
        for annotation in annotations:
            if annotation is not None:
                ids.update(id(n) for n in ast.walk(annotation))
    return ids


def test_type_only_imports_are_under_type_checking() -> None:
    """A module-level import used only in annotations must not cost an import at run time.

    Exempt: the CLI (Typer reads its annotations at run time), and names from a distribution
    the same file imports at run time anyway (``numpy.typing`` beside ``numpy``).
    """
    problems = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if PACKAGE / "cli" in path.parents:
            continue
        tree = ast.parse(path.read_text())
        imported: dict[str, tuple[str, int]] = {}
        for node in tree.body:
            if isinstance(node, ast.Import):
                for alias in node.names:
                    name = alias.asname or alias.name.split(".")[0]
                    imported[name] = (alias.name.split(".")[0], node.lineno)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                for alias in node.names:
                    imported[alias.asname or alias.name] = (node.module.split(".")[0], node.lineno)
        in_annotations = _annotation_nodes(tree)
        used = {
            n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and id(n) not in in_annotations
        }
        runtime_modules = {module for name, (module, _) in imported.items() if name in used}
        for name, (module, line) in imported.items():
            if module in sys.stdlib_module_names or module in OWN or module == "__future__":
                continue
            if name not in used and module not in runtime_modules:
                problems.append(f"{path.relative_to(REPO)}:{line}: {name} ({module}) only types")
    assert not problems, "\n".join(problems)
