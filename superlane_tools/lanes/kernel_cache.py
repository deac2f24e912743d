"""The lane fit's compiled kernels: their cache, compiling them in a child, loading them.

The one place that starts, awaits and stops the kernel compile: :func:`compiling` (the
context a run opens: a child process compiling on a cold cache, stopped when the run leaves it
behind), :func:`start_compiling` (the child itself), :func:`warm_up` /
:func:`warm_up_in_background` (wait for it and load the kernels in this process),
:func:`kernels_ready` / :func:`kernels_loading`.

Light on purpose (no numba, no scipy; the kernels are imported inside :func:`warm_up`):
``slt reprocess`` opens :func:`compiling` first thing, so that on the first run after an
install the compiler, which is that run's critical path, starts before the command's own
imports instead of after.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.lanes._cache_folder import (
    CACHE_ENV,
    COMPILE_NOTE,
    kernel_cache_dir,
    writable,
)

__all__ = [
    "CACHE_ENV",
    "COMPILE_NOTE",
    "KERNEL_SOURCES",
    "cache_is_cold",
    "compile_all",
    "compile_into_cache",
    "compiling",
    "is_compiling",
    "kernel_cache_dir",
    "kernels_loading",
    "kernels_ready",
    "mark_complete",
    "one_cpu_for",
    "start_compiling",
    "warm_up",
    "warm_up_in_background",
    "writable",
]

KERNEL_SOURCES = ("_kernels.py", "_refit_kernels.py")
"""The kernel modules beside this one; the completeness marker hashes them all."""
_COMPILE = "from superlane_tools.lanes.kernel_cache import compile_into_cache; compile_into_cache()"


def _complete_marker() -> Path | None:
    """The file that says the cache holds every kernel of these sources, numba and Python.

    None where the kernels' source or numba's version cannot be read (then numba's own checks
    decide, in process).
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        source = b"".join(Path(__file__).with_name(name).read_bytes() for name in KERNEL_SOURCES)
        tag = f"{version('numba')} {sys.version_info[:2]}".encode()
    except (OSError, PackageNotFoundError):
        return None
    digest = hashlib.blake2b(source + tag, digest_size=8).hexdigest()
    return kernel_cache_dir() / f"complete-{digest}"


def mark_complete() -> None:
    """Record that the cache holds every kernel (the compiler child ends with this).

    A changed kernel source (:data:`KERNEL_SOURCES`: an upgrade), numba or Python makes the
    cache cold again.
    """
    marker = _complete_marker()
    if marker is not None:
        with contextlib.suppress(OSError):
            marker.touch()


def compile_all() -> None:
    """Compile (or load from the cache) every kernel for the argument types the fit passes.

    Both kernel modules, from their argument types alone: no fit, no data, no scipy. The tests
    check that a fit afterwards compiles nothing more.
    """
    from superlane_tools.lanes import _kernels, _refit_kernels

    for module in (_kernels, _refit_kernels):
        for kernel, signature in module.signatures().items():
            kernel.compile(signature)


def compile_into_cache() -> None:
    """Compile every kernel into the cache, then mark it complete: what the compiler child runs.

    :func:`warm_up` loads the same kernels in process without marking anything.
    """
    compile_all()
    mark_complete()


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
    stderr. Wait for it, then load the kernels with :func:`warm_up` (which compiles in process,
    or raises, should the child have failed).
    """
    if not cache_is_cold():
        return None
    try:
        return subprocess.Popen([sys.executable, "-c", _COMPILE], stdout=subprocess.DEVNULL)
    except OSError:
        return None


def is_compiling(compiler: subprocess.Popen[bytes] | None) -> bool:
    """Return whether ``compiler`` (from :func:`compiling`) is still compiling."""
    return compiler is not None and compiler.poll() is None


@contextlib.contextmanager
def compiling() -> Iterator[subprocess.Popen[bytes] | None]:
    """Compile the kernels in a child while the block runs (on a cold cache; else None).

    Pass the child to :func:`warm_up_in_background` / :func:`warm_up`, which wait for it. A
    child still running when the block ends (the run failed, or fitted nothing) is stopped:
    no work is left behind.
    """
    compiler = start_compiling()
    try:
        yield compiler
    finally:
        if compiler is not None and compiler.poll() is None:
            compiler.terminate()
            compiler.wait()


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


_WARM_BACKENDS: set[str] = set()
_READY_BACKENDS: set[str] = set()
_LOADING_BACKENDS: set[str] = set()
_WARM_LOCK = threading.Lock()


def kernels_ready(backend: str = "numba") -> bool:
    """Return whether the fit can run on ``backend`` now, without loading kernels.

    True for the numpy reference and once :func:`warm_up` has finished (on any thread). A
    pipeline asks :func:`kernels_loading` instead, to keep its other stages busy meanwhile.
    """
    return backend != "numba" or backend in _READY_BACKENDS


def kernels_loading(backend: str = "numba") -> bool:
    """Return whether a :func:`warm_up_in_background` of ``backend`` is still running."""
    return backend in _LOADING_BACKENDS


def warm_up_in_background(
    backend: str = "numba", compiler: subprocess.Popen[bytes] | None = None
) -> None:
    """Load the kernels on a side thread (compiling them first in a child on a cold cache).

    The first run after an install compiles them (seconds, with a ``note:`` line) in a child
    process (``compiler`` when the caller started it, else started here); the side thread
    waits for it and loads the result while the caller's image stages run ahead. Nothing
    happens when ``backend`` needs no kernels or a warm-up already ran or runs; a failure is
    left to the fit itself to report.
    """
    if backend != "numba" or backend in _READY_BACKENDS or backend in _LOADING_BACKENDS:
        if compiler is not None and backend != "numba":
            compiler.terminate()  # the numpy reference needs no kernels
            compiler.wait()
        return
    _LOADING_BACKENDS.add(backend)
    compiler = compiler if compiler is not None else start_compiling()

    def warm() -> None:
        try:
            with contextlib.suppress(Exception):  # the fit raises the same error, with context
                warm_up(backend, compiler=compiler)
        finally:
            _LOADING_BACKENDS.discard(backend)

    threading.Thread(target=warm, name="slt-kernel-warm-up", daemon=True).start()


def warm_up(
    backend: str = "numba",
    *,
    compiler: subprocess.Popen[bytes] | None = None,
) -> float:
    """Load (or compile) the fit's kernels once per process, for the argument types it passes.

    :func:`~superlane_tools.lanes.multilane_fit.fit_frame` calls this before it starts its
    clock, so ``fit_time_s`` (and the TuSimple ``run_time`` derived from it) is the per-frame
    cost, not numba's one-off kernel loading (about 0.4 s from its cache, seconds when it must
    compile). Thread-safe: a call made while another thread warms up (``slt reprocess`` starts
    one early, on a side thread) waits for it, outside the caller's clock.

    Args:
        backend: ``numba`` or ``numpy`` (which needs no kernels).
        compiler: A child already compiling the kernels into the cache
            (:func:`start_compiling`): waited for, then its result is loaded.

    Returns:
        Seconds spent, 0 when the backend was already warm.
    """
    with _WARM_LOCK:
        if backend in _WARM_BACKENDS:
            return 0.0
        t0 = time.perf_counter()
        if compiler is not None:
            with one_cpu_for(compiler):
                try:
                    compiler.wait(timeout=900)
                except subprocess.TimeoutExpired:
                    compiler.kill()  # and compile here instead
                    compiler.wait()
        _WARM_BACKENDS.add(backend)
        if backend == "numba":
            compile_all()  # loads what the child compiled; compiles here should it have failed
        _READY_BACKENDS.add(backend)
        return time.perf_counter() - t0
