"""What a reader plug-in looks at to recognise its format: the name, a folder, the first bytes."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

HEAD_BYTES = 16
"""How many first bytes of a file the plug-ins see (magic numbers)."""
CERTAIN = 1 << 30
"""A plug-in's score for a magic number or a folder layout: beats any vote over text lines."""


class Probe(NamedTuple):
    """What a plug-in looks at to recognise its format.

    Attributes:
        path: The file or folder.
        is_dir: True for a folder.
        suffix: The file name's suffix in lower case (``""`` when none).
        head: The first :data:`HEAD_BYTES` bytes (empty for a folder).
    """

    path: Path
    is_dir: bool
    suffix: str
    head: bytes


def certain(found: bool) -> int:
    """Return :data:`CERTAIN` when ``found``, else 0."""
    return CERTAIN if found else 0
