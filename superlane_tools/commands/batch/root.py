"""The batch output root: one batch at a time (a lock), and what killed runs left behind."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.commands.batch.engine import TMP_DIR
from superlane_tools.commands.batch.errors import BatchError
from superlane_tools.reporting.atomic import pid_alive

LOCK_FILE = ".batch.lock"


@contextlib.contextmanager
def root_lock(root: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``root`` for one batch; remove the lock file when done.

    The lock is an ``flock`` on ``root/.batch.lock``, so the kernel releases it when the process
    dies, however it dies: a file that a killed batch (SIGKILL, power loss) left behind is
    stale, and the next batch takes it over. On every other exit, error included, the file is
    removed while the lock is still held. A batch that opened the file just before another
    removed it would lock a deleted file: after locking, the path must still name the locked
    file, otherwise the lock is taken again on the new one.

    Raises:
        BatchError: If the root cannot be created or another batch holds the lock.
    """
    import fcntl

    path = root / LOCK_FILE
    for _ in range(_LOCK_ATTEMPTS):
        try:
            root.mkdir(parents=True, exist_ok=True)
            handle = path.open("a+")
        except OSError as err:
            raise BatchError(f"output root {root} is not writable: {err.strerror}") from err
        try:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError as err:
                raise BatchError(f"another slt batch is running on {root}{_owner(path)}") from err
            if not _same_file(handle.fileno(), path):
                continue  # removed by the batch that just finished: lock the new one
            try:
                handle.seek(0)
                handle.truncate()
                handle.write(f"pid {os.getpid()} on {socket.gethostname()}\n")
                handle.flush()
            except OSError as err:  # a full disk or quota: say so, not a traceback
                raise BatchError(f"cannot write {path}: {err.strerror}") from err
            try:
                yield
            finally:
                path.unlink(missing_ok=True)
            return
        finally:
            with contextlib.suppress(OSError):  # the write error, if any, is raised above
                handle.close()
    raise BatchError(f"could not take the lock {path}: it keeps being replaced")


_LOCK_ATTEMPTS = 10


def _same_file(fd: int, path: Path) -> bool:
    """Return True if ``path`` exists and is the file open as ``fd``."""
    try:
        named = path.stat()
    except FileNotFoundError:
        return False
    held = os.fstat(fd)
    return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


def _owner(path: Path) -> str:
    """Return `` (pid N on HOST)`` from a held lock file, or nothing if it cannot be read."""
    try:
        text = path.read_text(errors="replace").strip()
    except OSError:
        return ""
    return f" ({text})" if text else ""


def clean_stale_tmp(root: Path) -> list[Path]:
    """Remove what killed runs left: ``root/.tmp`` folders and half-written ``.*.tmp`` files.

    A folder named ``<id>.<host>.<pid>[.old]`` is kept only while that process on this host
    is alive (a local worker of a killed run exits within a second of its driver, see
    :func:`~.worker.init_worker`); with the root lock held no other batch is writing here.
    """
    from superlane_tools.reporting.layout import SUMMARY_DIR

    # the driver's own atomic writes (status table, summary) killed mid-write: with the lock
    # held, no process is writing them now
    removed = [p for p in root.glob(".*.tmp") if p.is_file()]
    removed += [p for p in (root / SUMMARY_DIR).glob(".*.tmp") if p.is_file()]
    for leftover in removed:
        leftover.unlink(missing_ok=True)
    tmp_root = root / TMP_DIR
    if not tmp_root.is_dir():
        return removed
    host = socket.gethostname()
    for entry in sorted(tmp_root.iterdir()):
        _, _, owner = entry.name.removesuffix(".old").partition(".")
        owner_host, _, pid_text = owner.rpartition(".")
        if pid_text.isdigit() and owner_host == host and pid_alive(int(pid_text)):
            continue
        if entry.is_dir():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed
