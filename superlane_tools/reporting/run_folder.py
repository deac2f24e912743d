"""Whole-run atomicity: build a run folder in a staging folder, publish it with one rename.

A run folder (``slt reprocess --out``) is complete only when it holds :data:`RUN_MANIFEST`, written
last, listing every file of the run with its size. Readers (``slt tables``) call
:func:`require_complete_run` and refuse anything else, so a folder from a killed or failed run
can never be read as a result. Staging folders of killed runs (``.<name>.slt-staging.<pid>.*``
beside the target) are removed by the next run into the same target.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.reporting.atomic import pid_alive, write_text_atomic
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.layout import MANIFEST_FILE as RUN_MANIFEST

_STAGING = "slt-staging"
_OLD = "slt-old"
_RENAME_EXCHANGE = 2  # renameat2 flag (Linux >= 3.15)
_AT_FDCWD = -100
_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG, errno.EACCES, errno.EPERM}


def clean_stale(final: str | os.PathLike[str]) -> list[Path]:
    """Remove what killed runs into ``final`` left beside it; return the removed paths.

    Staging and replaced folders carry the id of the process that made them; those of processes
    that no longer run are removed. Stale ``.<name>.*.tmp`` files of atomic writes inside an
    existing run folder are removed too.
    """
    target = Path(final)
    removed: list[Path] = []
    parent = target.parent if str(target.parent) else Path()
    with contextlib.suppress(OSError):
        for entry in parent.glob(f".{target.name}.slt-*"):
            parts = entry.name[len(target.name) + 2 :].split(".")
            if len(parts) < 2 or parts[0] not in {_STAGING, _OLD} or not parts[1].isdigit():
                continue
            if pid_alive(int(parts[1])) and int(parts[1]) != os.getpid():
                continue
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    if target.is_dir():
        with contextlib.suppress(OSError):
            for tmp in target.glob(".*.tmp"):
                if tmp.is_file():
                    tmp.unlink()
                else:
                    shutil.rmtree(tmp, ignore_errors=True)
                removed.append(tmp)
    return removed


def _files(folder: Path) -> dict[str, int]:
    listing: dict[str, int] = {}
    for root, dirs, names in os.walk(folder):
        dirs.sort()
        for name in sorted(names):
            path = Path(root) / name
            rel = path.relative_to(folder).as_posix()
            if rel != RUN_MANIFEST:
                listing[rel] = path.stat().st_size
    return listing


def write_run_manifest(folder: str | os.PathLike[str]) -> Path:
    """Write :data:`RUN_MANIFEST` into ``folder`` listing its files and sizes; call it last.

    Raises:
        OutputError: If the folder cannot be listed or the manifest written.
    """
    root = Path(folder)
    try:
        files = _files(root)
    except OSError as err:
        raise OutputError(f"cannot list {root}: {err.strerror}") from err
    text = json.dumps({"format": 1, "complete": True, "files": files}, indent=1)
    return write_text_atomic(root / RUN_MANIFEST, text + "\n")


def require_complete_run(folder: str | os.PathLike[str]) -> None:
    """Raise unless ``folder`` is a complete run: a manifest whose files all exist, same sizes.

    Raises:
        OutputError: Naming what is missing (a killed, failed or foreign folder).
    """
    root = Path(folder)
    manifest = root / RUN_MANIFEST
    try:
        data = json.loads(manifest.read_text(encoding="utf-8"))
        files = data["files"]
        if data.get("complete") is not True or not isinstance(files, dict):
            raise ValueError("incomplete")
    except FileNotFoundError:
        raise OutputError(
            f"{root}: not a complete reprocess run folder (no {RUN_MANIFEST}: "
            "the run was killed or failed, or the folder is not a run); rerun slt reprocess"
        ) from None
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise OutputError(f"{root}: unreadable {RUN_MANIFEST} ({err}); rerun reprocess") from err
    for rel, size in files.items():
        path = root / str(rel)
        try:
            actual = path.stat().st_size
        except OSError:
            raise OutputError(
                f"{root}: incomplete reprocess run: {rel} is missing; rerun slt reprocess"
            ) from None
        if actual != size:
            raise OutputError(
                f"{root}: incomplete reprocess run: {rel} changed size since the run; "
                "rerun slt reprocess"
            )


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2``); False where that is unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        func = libc.renameat2
    except (OSError, AttributeError):
        return False
    func.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    res = func(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    return bool(res == 0)


def _publish(staging: Path, final: Path) -> None:
    """Make ``staging`` appear at ``final`` in one step, replacing a previous run there."""
    if not final.exists():
        staging.rename(final)
        return
    if _exchange(staging, final):
        shutil.rmtree(staging, ignore_errors=True)  # now holds the previous run
        return
    old = final.with_name(f".{final.name}.{_OLD}.{os.getpid()}.{os.urandom(3).hex()}")
    final.rename(old)
    staging.rename(final)
    shutil.rmtree(old, ignore_errors=True)


def _check_target(final: Path) -> None:
    if final.exists() and not final.is_dir():
        raise OutputError(f"{final} exists and is not a folder; choose another --out")
    if final.is_dir() and not (final / RUN_MANIFEST).is_file():
        try:
            foreign = [p.name for p in final.iterdir() if not p.name.endswith(".tmp")]
        except OSError as err:
            raise OutputError(f"cannot read {final}: {err.strerror}") from err
        if foreign:
            raise OutputError(
                f"{final} is not empty and not a complete slt run folder (no {RUN_MANIFEST}); "
                "remove it or choose another --out"
            )


@contextlib.contextmanager
def staged_run(final: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a staging folder for a whole run; publish it at ``final`` if the block succeeds.

    The run is written into ``.<name>.slt-staging.<pid>.<random>`` beside ``final``; on success
    :data:`RUN_MANIFEST` is written last and the folder replaces ``final`` with one rename
    (an atomic exchange when ``final`` holds a previous run). On failure, or when the process is
    killed, ``final`` is untouched: it holds the previous complete run or nothing. Leftovers of
    killed runs are removed first. A non-empty ``final`` that is not a run folder is refused, so
    no user file is ever replaced.

    Raises:
        OutputError: If ``final`` is a file or a foreign folder, or staging/publishing fails.
    """
    target = Path(final)
    clean_stale(target)
    _check_target(target)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(
            tempfile.mkdtemp(
                prefix=f".{target.name}.{_STAGING}.{os.getpid()}.", dir=target.parent or None
            )
        )
        staging.chmod(0o777 & ~_umask())
        _publish_probe(target)
    except OSError as err:
        raise OutputError(f"cannot write {target}: {err.strerror}") from err
    try:
        yield staging
        write_run_manifest(staging)
        _publish(staging, target)
    except OSError as err:
        if err.errno not in _WRITE_ERRNOS:
            raise
        raise OutputError(f"cannot write {target}: {err.strerror}") from err
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)


def _publish_probe(target: Path) -> None:
    """Fail early when the folder that will hold ``target`` is not writable."""
    if not os.access(target.parent if str(target.parent) else ".", os.W_OK):
        raise PermissionError(errno.EACCES, "permission denied", str(target.parent))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
