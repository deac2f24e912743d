"""The lane fit's compiled-kernel cache folder: where it is and whether it takes files.

Light (no numba): both :mod:`superlane_tools.lanes.kernel_cache` (which starts and awaits the
compile) and the kernel modules, which cache into this folder, import it.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from superlane_tools.errors import message_line

CACHE_ENV = "SLT_CACHE_DIR"
"""Environment variable naming superlane-tools' cache root (kernels go to its ``numba/``)."""
COMPILE_NOTE = message_line("note", "compiling lane-fit kernels (first run only)")


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
