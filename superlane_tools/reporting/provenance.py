"""Provenance stored in every output file: tool version, models, config and input identity."""

from __future__ import annotations

import hashlib
import json
import os
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, NamedTuple, TypeAlias

from superlane_tools._version import __version__
from superlane_tools.reporting.errors import OutputError

METADATA_KEY = b"superlane_tools"
_CHUNK = 1 << 20
_BLAKE3_CHUNK = 4 << 20  # blake3 releases the GIL on large updates; fewer, larger reads
HashAlgorithm = Literal["blake3", "sha256"]
"""Content hash of an input identity: BLAKE3 (the default, about 4x faster than SHA-256 on
one core here) or SHA-256 (kept for files whose tables name a SHA-256 column)."""
CONTENT_HASH: HashAlgorithm = "blake3"
"""Algorithm of :func:`input_identity`; batch idempotency keys are built on its digests."""


class InputIdentity(NamedTuple):
    """Identity of one input file (or recording folder).

    Attributes:
        name: File or folder name (no directories, so identities compare across machines).
        size_bytes: Total size in bytes.
        content_hash: ``"<algorithm>:<hex digest>"`` of the content (for a folder: of its
            files' names and digests), e.g. ``blake3:9f86...``. The algorithm is part of the
            value, so identities hashed with different algorithms never compare equal.
    """

    name: str
    size_bytes: int
    content_hash: str

    @property
    def algorithm(self) -> str:
        """Return the hash algorithm of :attr:`content_hash`."""
        return self.content_hash.partition(":")[0]

    @property
    def hex_digest(self) -> str:
        """Return the hex digest of :attr:`content_hash`, without the algorithm."""
        return self.content_hash.partition(":")[2]


class HashCancelledError(Exception):
    """A background identity computation was cancelled (see :class:`PendingIdentities`)."""


def _sha256(path: str | os.PathLike[str], stop: threading.Event | None) -> str:
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
            if stop is not None and stop.is_set():
                raise HashCancelledError
    return digest.hexdigest()


def _blake3(path: str | os.PathLike[str], stop: threading.Event | None) -> str:
    from blake3 import blake3

    digest = blake3(max_threads=1)  # one core: the command's own work runs on the other
    buffer = bytearray(_BLAKE3_CHUNK)
    view = memoryview(buffer)
    with Path(path).open("rb", buffering=0) as handle:
        while n := handle.readinto(buffer):
            digest.update(view[:n])
            if stop is not None and stop.is_set():
                raise HashCancelledError
    return str(digest.hexdigest())


def _file_digest(
    path: str | os.PathLike[str], stop: threading.Event | None, algorithm: HashAlgorithm
) -> str:
    return _blake3(path, stop) if algorithm == "blake3" else _sha256(path, stop)


def file_sha256(path: str | os.PathLike[str]) -> str:
    """Return the hex SHA-256 of a file's content, read in 1 MiB chunks."""
    return _sha256(path, None)


def _identity(
    path: str | os.PathLike[str],
    stop: threading.Event | None,
    algorithm: HashAlgorithm = CONTENT_HASH,
) -> InputIdentity:
    src = Path(path)
    if src.is_dir():
        listing = hashlib.sha256() if algorithm == "sha256" else _new_blake3()
        size = 0
        for item in sorted(p for p in src.rglob("*") if p.is_file()):
            rel = item.relative_to(src).as_posix()
            part = _file_digest(item, stop, algorithm)
            listing.update(rel.encode() + b"\0" + part.encode() + b"\n")
            size += item.stat().st_size
        return InputIdentity(src.name, size, f"{algorithm}:{listing.hexdigest()}")
    digest = _file_digest(src, stop, algorithm)
    return InputIdentity(src.name, src.stat().st_size, f"{algorithm}:{digest}")


def _new_blake3() -> Any:
    from blake3 import blake3

    return blake3()


def input_identity(
    path: str | os.PathLike[str], algorithm: HashAlgorithm = CONTENT_HASH
) -> InputIdentity:
    """Return the identity of a file, or of a folder (e.g. a ROS 2 bag) from its files.

    Args:
        path: Input file or folder.
        algorithm: Content hash (BLAKE3 unless a caller's schema names SHA-256).
    """
    return _identity(path, None, algorithm)


class PendingIdentities:
    """Input identities hashed in a background thread while the caller does other work.

    blake3 (and hashlib) and file reads release the GIL, so hashing a large recording overlaps
    with reading and decoding it. The thread is a daemon and stops early on :meth:`cancel`.

    Args:
        paths: Input files or folders, in the order :meth:`result` returns them.
    """

    def __init__(self, paths: Sequence[str | os.PathLike[str]]) -> None:
        self._paths = tuple(paths)
        self._stop = threading.Event()
        self._result: tuple[InputIdentity, ...] | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="slt-hash", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self._result = tuple(_identity(p, self._stop) for p in self._paths)
        except BaseException as err:  # handed to the caller by result()
            self._error = err

    def result(self) -> tuple[InputIdentity, ...]:
        """Wait for the identities and return them.

        Raises:
            OSError: If an input could not be read.
            HashCancelledError: If :meth:`cancel` stopped the hashing first.
        """
        self._thread.join()
        if self._stop.is_set():
            raise HashCancelledError("input hashing was cancelled")
        if self._error is not None:
            raise self._error
        assert self._result is not None
        return self._result

    def cancel(self) -> None:
        """Stop hashing soon (within one 1 MiB read); :meth:`result` raises from now on."""
        self._stop.set()


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


ProvenanceSource: TypeAlias = Provenance | Callable[[], Provenance]
"""A provenance, or a function that returns it when it is first needed (e.g. after hashing)."""


def resolve_provenance(source: ProvenanceSource) -> Provenance:
    """Return ``source`` itself, or call it to get the provenance."""
    return source if isinstance(source, Provenance) else source()


class HashedProvenance:
    """A provenance finished once the inputs' background hashing is done.

    The inputs are hashed (BLAKE3) in a background thread while a command reads them; the
    Parquet writers call this object when they first need the provenance.
    """

    def __init__(self, pending: PendingIdentities, command: str, config: dict[str, Any]) -> None:
        self._pending = pending
        self._command = command
        self._config = config
        self._provenance: Provenance | None = None

    def __call__(self) -> Provenance:
        """Return the provenance, waiting for the hashes if needed.

        Raises:
            OutputError: If an input could not be read for hashing.
        """
        if self._provenance is None:
            try:
                inputs = self._pending.result()
            except OSError as err:
                raise OutputError(f"cannot hash input {err.filename}: {err.strerror}") from err
            self._provenance = Provenance(command=self._command, inputs=inputs, config=self._config)
        return self._provenance

    def cancel(self) -> None:
        """Stop hashing (the extraction failed)."""
        self._pending.cancel()
