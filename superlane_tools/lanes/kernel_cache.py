"""Where the lane fit's compiled kernels are cached, and compiling them in a child process.

Light on purpose (no numba, no scipy): ``slt reprocess`` asks :func:`cache_is_cold` and calls
:func:`start_compiling` first thing, so that on the first run after an install the compiler,
which is that run's critical path, starts before the command's own imports instead of after.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.errors import message_line

CACHE_ENV = "SLT_CACHE_DIR"
"""Environment variable naming superlane-tools' cache root (kernels go to its ``numba/``)."""
COMPILE_NOTE = message_line("note", "compiling lane-fit kernels (first run only)")
_COMPILE = "from superlane_tools.lanes._kernels import compile_all; compile_all()"


def kernel_cache_dir() -> Path:
    """Return the folder of the compiled-kernel cache (it may not exist yet).

    ``$SLT_CACHE_DIR/numba`` when set, else ``$XDG_CACHE_HOME/superlane-tools/numba``, else the
    platform's user cache folder (``~/.cache`` on Linux, ``~/Library/Caches`` on macOS,
    ``%LOCALAPPDATA%`` on Windows) ``/superlane-tools/numba``.
    """
    root = os.environ.get(CACHE_ENV)
    if root:
        return Path(root).expanduser() / "numba"
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg:
        base = Path(xdg).expanduser()
    elif sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        base = Path(os.environ["LOCALAPPDATA"])
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        base = Path.home() / ".cache"
    return base / "superlane-tools" / "numba"


def writable(folder: Path) -> bool:
    """Return whether ``folder`` exists (it is created if missing) and takes new files."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def _complete_marker() -> Path | None:
    """The file that says the cache holds every kernel of this source, numba and Python.

    None where the kernels' source or numba's version cannot be read (then numba's own checks
    decide, in process).
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        source = Path(__file__).with_name("_kernels.py").read_bytes()
        tag = f"{version('numba')} {sys.version_info[:2]}".encode()
    except (OSError, PackageNotFoundError):
        return None
    digest = hashlib.blake2b(source + tag, digest_size=8).hexdigest()
    return kernel_cache_dir() / f"complete-{digest}"


def mark_complete() -> None:
    """Record that the cache holds every kernel (``_kernels.compile_all`` ends with this).

    A changed ``_kernels.py`` (an upgrade), numba or Python makes the cache cold again.
    """
    marker = _complete_marker()
    if marker is not None:
        with contextlib.suppress(OSError):
            marker.touch()


def cache_is_cold() -> bool:
    """Return True when the kernels would compile here: a writable cache not marked complete.

    False where no cache folder is writable (a separate process could not hand its compiled
    kernels over) or the marker cannot be named.
    """
    marker = _complete_marker()
    return marker is not None and writable(kernel_cache_dir()) and not marker.exists()


def start_compiling() -> subprocess.Popen[bytes] | None:
    """On a cold cache, start compiling the kernels into it in a child process; else None.

    numba's compiler is Python holding the GIL: in a child it runs on the other core instead
    of slowing this process. The child prints the one :data:`COMPILE_NOTE` line to the shared
    stderr. Wait for it, then load the kernels with
    :func:`superlane_tools.lanes.multilane_fit.warm_up` (which compiles in process, or raises,
    should the child have failed).
    """
    if not cache_is_cold():
        return None
    try:
        return subprocess.Popen([sys.executable, "-c", _COMPILE], stdout=subprocess.DEVNULL)
    except OSError:
        return None


_TASKS = Path("/proc/self/task")


def _set_threads_affinity(cpus: set[int]) -> None:
    """Bind every thread of this process (Linux tasks) to ``cpus``; threads that end are fine."""
    for task in _TASKS.iterdir():
        with contextlib.suppress(OSError):
            os.sched_setaffinity(int(task.name), cpus)


@contextlib.contextmanager
def one_cpu_for(compiler: subprocess.Popen[bytes]) -> Iterator[None]:
    """Give ``compiler`` a CPU of its own while the block runs; this process keeps the others.

    The compiler is the first run's critical path: the sooner it ends, the sooner the image
    stages use every CPU again. Where the platform cannot bind threads to CPUs (not Linux)
    or there is a single CPU, nothing changes.
    """
    if not hasattr(os, "sched_setaffinity") or not _TASKS.is_dir():
        yield
        return
    everything = os.sched_getaffinity(0)
    if len(everything) < 2:
        yield
        return
    theirs = {max(everything)}
    try:
        os.sched_setaffinity(compiler.pid, theirs)
        _set_threads_affinity(everything - theirs)
    except OSError:  # e.g. the child already ended
        _set_threads_affinity(everything)
        yield
        return
    try:
        yield
    finally:
        _set_threads_affinity(everything)  # also the threads started meanwhile
