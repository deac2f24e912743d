"""Provenance stored in every output file: tool version, models, config and input identity."""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools._version import __version__

METADATA_KEY = b"superlane_tools"
_CHUNK = 1 << 20


class InputIdentity(NamedTuple):
    """Identity of one input file (or recording folder).

    Attributes:
        name: File or folder name (no directories, so identities compare across machines).
        size_bytes: Total size in bytes.
        sha256: Hex SHA-256 of the content (for a folder: of its files' names and hashes).
    """

    name: str
    size_bytes: int
    sha256: str


def file_sha256(path: str | os.PathLike[str]) -> str:
    """Return the hex SHA-256 of a file's content, read in 1 MiB chunks."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def input_identity(path: str | os.PathLike[str]) -> InputIdentity:
    """Return the identity of a file, or of a folder (e.g. a ROS 2 bag) from its files."""
    src = Path(path)
    if src.is_dir():
        digest = hashlib.sha256()
        size = 0
        for item in sorted(p for p in src.rglob("*") if p.is_file()):
            rel = item.relative_to(src).as_posix()
            digest.update(rel.encode() + b"\0" + file_sha256(item).encode() + b"\n")
            size += item.stat().st_size
        return InputIdentity(src.name, size, digest.hexdigest())
    return InputIdentity(src.name, src.stat().st_size, file_sha256(src))


@dataclass(frozen=True)
class Provenance:
    """Where an output came from; serialised as JSON into file metadata.

    Attributes:
        command: The command line (or library call) that produced the output.
        inputs: Identities of the input files.
        config: The effective configuration (JSON-serialisable).
        models: Model name -> SHA-256 of the model file used.
        tool_version: superlane-tools version.
    """

    command: str = ""
    inputs: tuple[InputIdentity, ...] = ()
    config: Mapping[str, Any] = field(default_factory=dict)
    models: Mapping[str, str] = field(default_factory=dict)
    tool_version: str = __version__

    def to_json(self) -> str:
        """Return the provenance as a JSON string."""
        return json.dumps(
            {
                "tool": "superlane-tools",
                "tool_version": self.tool_version,
                "command": self.command,
                "inputs": [i._asdict() for i in self.inputs],
                "config": dict(self.config),
                "models": dict(self.models),
            },
            sort_keys=True,
            default=str,
        )
