"""The reader plug-ins are the only home of format knowledge.

No module outside ``recording/open.py`` (the plug-in table) and ``recording/formats/`` (each
format's magic numbers, suffixes and folder rule) spells a recording's magic number, the ROS 2
bag folder's ``metadata.yaml`` or a recording suffix: everything else asks the table or imports
the format's constants. The magic numbers and suffixes checked are the ones the plug-ins declare,
so a new plug-in is covered as soon as it is in :data:`READERS`. Read with ``ast``: docstrings
and messages that only mention a format are not format tests.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

from superlane_tools.recording.open import READERS

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "superlane_tools"
HOMES = ("recording/open.py", "recording/formats/")
"""Where format knowledge may be spelled (relative to the package)."""

GENERIC_SUFFIXES = frozenset({".txt", ".csv"})
"""Suffixes a plug-in reads by content but that name many other files (manifests, lists)."""
FOLDER_FILES = frozenset({"metadata.yaml"})
"""Files whose presence makes a folder a recording (the ROS 2 bag folder rule)."""
EXEMPT: dict[str, str] = {}
"""Known leftovers (module -> the literal it may still hold); none today."""


def _suffixes() -> frozenset[str]:
    found = {s for p in READERS for s in (*p.claims, *p.suffixes)}
    found |= {p.output_suffix for p in READERS if p.output_suffix}
    return frozenset(found - GENERIC_SUFFIXES)


def _magics() -> tuple[bytes, ...]:
    return tuple(m for p in READERS for m in p.magic)


def _docstrings(tree: ast.AST) -> set[int]:
    """Return the ids of the docstring constants of a module, its classes and functions."""
    ids: set[int] = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        first = body[0] if isinstance(body, list) and body else None
        if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
            ids.add(id(first.value))
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            ids.add(id(node.value))  # attribute docstrings after an assignment
    return ids


def _suffix_keywords(tree: ast.AST) -> set[int]:
    """Return the ids of ``suffix=".mcap"`` keyword values: naming a temporary file, no test."""
    return {
        id(node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.keyword)
        and node.arg == "suffix"
        and isinstance(node.value, ast.Constant)
    }


def _is_magic(value: bytes, magics: tuple[bytes, ...]) -> bool:
    if len(value) < 4:
        return False
    return any(value[:4] == m[:4] or m in value for m in magics)


def format_literals(source: str) -> Iterator[tuple[int, str]]:
    """Yield ``(line, literal)`` for every magic number, folder file or recording suffix."""
    tree = ast.parse(source)
    skip = _docstrings(tree) | _suffix_keywords(tree)
    suffixes, magics = _suffixes(), _magics()
    for node in ast.walk(tree):
        if not isinstance(node, ast.Constant) or id(node) in skip:
            continue
        value = node.value
        magic = isinstance(value, bytes) and _is_magic(value, magics)
        named = isinstance(value, str) and (
            value.lower() in suffixes or value in FOLDER_FILES or value.endswith("/metadata.yaml")
        )
        if magic or named:
            yield node.lineno, repr(value)


def _modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _is_home(rel: str) -> bool:
    return any(rel == home or rel.startswith(home) for home in HOMES)


def test_the_plug_ins_declare_magic_numbers_and_suffixes() -> None:
    assert {b"\x89MCAP0\r\n", b"#ROSBAG V2.0\n", b"SQLite format 3\x00"} <= set(_magics())
    assert {".mcap", ".bag", ".db3", ".asc", ".blf", ".mp4"} <= _suffixes()


@pytest.mark.parametrize(
    ("source", "found"),
    [
        ('if head.startswith(b"\\x89MCAP"):\n    pass\n', 1),
        ('MAGIC = b"#ROSBAG V2.0"\n', 1),
        ('ok = (path / "metadata.yaml").is_file()\n', 1),
        ('is_bag = path.suffix in {".bag", ".db3"}\n', 2),
        ('if out.suffix != ".MCAP":\n    pass\n', 1),
        ('def f():\n    """Read a ``.bag`` or ``metadata.yaml``."""\n', 0),
        ('raise ValueError("an MCAP filters to OUT.mcap")\n', 0),
        ('tmp = atomic_path(path, suffix=".mcap")\n', 0),
        ('PNG = b"\\x89PNG\\r\\n\\x1a\\n"\n', 0),
    ],
)
def test_the_check_finds_format_literals(source: str, found: int) -> None:
    assert len(list(format_literals(source))) == found


def test_format_knowledge_lives_only_in_the_reader_plug_ins() -> None:
    offenders: list[str] = []
    used: set[str] = set()
    for path in _modules():
        rel = path.relative_to(PACKAGE).as_posix()
        if _is_home(rel):
            continue
        for line, literal in format_literals(path.read_text(encoding="utf-8")):
            if EXEMPT.get(rel) == literal.strip("'\""):
                used.add(rel)
                continue
            offenders.append(f"superlane_tools/{rel}:{line}: {literal}")
    assert not offenders, (
        "format knowledge outside the reader plug-ins (ask recording.open's table or import "
        "the constant from recording.formats):\n" + "\n".join(offenders)
    )
    assert used == set(EXEMPT), f"stale exemptions, remove them: {sorted(set(EXEMPT) - used)}"


def test_the_homes_exist() -> None:
    for home in HOMES:
        assert (PACKAGE / home).exists(), home
    names = {p.stem for p in (PACKAGE / "recording/formats").glob("*.py")} - {"__init__", "probe"}
    assert {p.name for p in READERS} == names, "one module in recording/formats/ per plug-in"
