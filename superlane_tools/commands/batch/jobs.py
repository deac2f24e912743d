"""The types of a job kind: what one batch job does to one recording.

A kind (in :mod:`superlane_tools.commands.batch.kinds`, one module each) is four plain
functions, looked up by name in each worker (so only the name travels):
``check`` validates the configuration in the driver, ``identities`` names the model and data
files (with their SHA-256) that enter the idempotency key, ``load`` runs once per worker
(ONNX sessions, DBCs) and ``run`` processes one recording into a folder.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NamedTuple


class JobResult(NamedTuple):
    """What a job kind's ``run`` produced in its output folder.

    Attributes:
        status: ``ok``, or ``partial`` when input data was lost or skipped.
        note: One line on what was lost (``partial``), else ``""``.
        outputs: Files written.
        frames: Frames processed.
        timings: Stage name -> seconds.
    """

    status: str
    note: str
    outputs: int
    frames: int
    timings: Mapping[str, float]


class JobKind(NamedTuple):
    """The functions of one job kind (see the module docstring)."""

    name: str
    check: Callable[[Mapping[str, Any]], None]
    identities: Callable[[Mapping[str, Any]], dict[str, str]]
    load: Callable[[Mapping[str, Any]], Any]
    run: Callable[[Path, Path, Mapping[str, Any], Any], JobResult]
    split_sequences: bool = True
    """True: one job per manifest sequence (config keys ``start_s``/``end_s``). False: one job
    per recording, its sequences passed as ``segments`` and its ``category`` in the config."""
    preload: tuple[str, ...] = ()
    """Modules the local engine's fork server imports once, so that each worker process starts
    with them instead of importing them for its first recording (imports only: they must not
    start threads before the fork)."""


def load_config_file(path: str | Path) -> dict[str, Any]:
    """Read a job configuration mapping from a ``.toml``, ``.yaml``/``.yml`` or ``.json`` file.

    Raises:
        ConfigError: If the file cannot be read or is not a mapping.
    """
    from superlane_tools.config_files import load_mapping

    return load_mapping(path)
