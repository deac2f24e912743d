"""Atomic file output: write to a temporary sibling, then rename over the target."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.reporting.errors import OutputError

_TEMP_NAME = re.compile(r"^\..+\.(\d+)\.[a-z0-9_]{8}(?:\.[^.]+)?\.(?:tmp|old)$")


def temp_prefix(name: str) -> str:
    """Prefix of a temporary file or folder for ``name``: it carries this process's id."""
    return f".{name}.{os.getpid()}."


def pid_alive(pid: int) -> bool:
    """Return True when process ``pid`` runs on this machine (this process included)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


def remove_stale_temps(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove temporary files and folders in ``folder`` left by processes that were killed.

    Only names made with :func:`temp_prefix` are touched, and only when the process that
    made them no longer runs; returns what was removed.
    """
    removed: list[Path] = []
    try:
        entries = list(Path(folder).iterdir())
    except OSError:
        return removed
    for entry in entries:
        match = _TEMP_NAME.match(entry.name)
        if match is None or pid_alive(int(match.group(1))):
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                entry.unlink()
        removed.append(entry)
    return removed


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str], suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside ``target``; rename it to ``target`` if the block succeeds.

    A killed process leaves at most a ``.<name>.*.tmp`` file, never a half-written target.

    Args:
        target: Final path of the file.
        suffix: Extra suffix for the temporary name (some writers infer formats from it).

    Raises:
        OutputError: If the folder cannot be created or the rename fails.
    """
    final = Path(target)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(
            prefix=temp_prefix(final.name), suffix=f"{suffix}.tmp", dir=final.parent
        )
    except OSError as err:
        raise OutputError(f"cannot write {final}: {err.strerror}") from err
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        tmp.chmod(0o666 & ~umask)  # mkstemp creates 0600; give the usual file mode
        tmp.replace(final)
    except OSError as err:
        raise OutputError(f"cannot write {final}: {err.strerror}") from err
    finally:
        if tmp.exists():
            tmp.unlink()


def write_bytes_atomic(target: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``target`` atomically and return the final path."""
    with atomic_path(target) as tmp:
        tmp.write_bytes(data)
    return Path(target)


def write_text_atomic(target: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` to ``target`` atomically and return the final path."""
    return write_bytes_atomic(target, text.encode("utf-8"))


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()


def settle_replaced(target: str | os.PathLike[str]) -> list[Path]:
    """Settle what a killed :func:`replacing` left beside ``target``; return the paths touched.

    An old output set aside by a process that no longer runs is put back when ``target`` is
    missing (the kill came before the new output appeared), else removed (the new output is
    there: the replacement the user asked for had happened).
    """
    final = Path(target)
    touched: list[Path] = []
    parent = final.parent if str(final.parent) else Path()
    aside = re.compile(rf"^\.{re.escape(final.name)}\.(\d+)\.[0-9a-f]{{8}}\.old$")
    with contextlib.suppress(OSError):
        for entry in sorted(parent.iterdir()):
            match = aside.match(entry.name)
            if match is None or pid_alive(int(match[1])):
                continue
            if os.path.lexists(final):
                _remove(entry)
            else:
                entry.rename(final)
            touched.append(entry)
    return touched


@contextlib.contextmanager
def replacing(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Set an existing output aside while the block writes a new one at ``target``.

    The old output (a file or a folder) is renamed to ``.<name>.<pid>.<random>.old`` beside
    it, so the block writes into a path that does not exist and nothing of the old output
    survives in the new one. When the block succeeds the old output is removed; when it raises,
    whatever the block left at ``target`` is removed and the old output is put back. A killed
    process leaves the ``.old`` name, which :func:`remove_stale_temps` removes.

    Raises:
        OutputError: If the old output cannot be set aside.
    """
    final = Path(target)
    if not os.path.lexists(final):
        yield final
        return
    aside = final.with_name(f"{temp_prefix(final.name)}{os.urandom(4).hex()}.old")
    try:
        final.rename(aside)
    except OSError as err:
        raise OutputError(f"cannot replace {final}: {err.strerror}") from err
    try:
        yield final
    except BaseException:
        if os.path.lexists(final):
            _remove(final)
        aside.rename(final)
        raise
    _remove(aside)
