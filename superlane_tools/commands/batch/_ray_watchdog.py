"""A watchdog that stops the local Ray instance of one ``slt batch`` when its driver goes away.

``ray.init()`` without an address starts a private Ray instance (GCS, raylet, dashboard and
runtime-env agents, workers). Ray ties most of them to the driver, but a SIGKILLed driver (OOM
killer, ``kill -9``, a scheduler's hard stop) leaves some running: measured with Ray 2.60,
``ray::DashboardAgent`` and ``ray::RuntimeEnvAgent`` survive indefinitely. So before it starts
the instance, :class:`RayWatchdog` starts this module as a small stdlib-only process in its own
session, connected to the driver by a pipe only the driver holds, and marks the instance: every
process Ray starts inherits ``SLT_RAY_OWNER=<token>`` in its environment. When the pipe closes
(the driver finished, failed or was killed: the kernel closes it in every case), the watchdog
sends SIGTERM, then SIGKILL after a grace period, to every process of exactly that instance,
until none is left: the processes carrying the token, or the instance's node id
(``RAY_NODE_ID``), or holding a file of its session folder open (the agents the raylet starts
lack the token, and their title may blank their environment). Other Ray instances of the user
have neither and are never touched.

The sweep reads ``/proc`` and so works on Linux only; elsewhere the watchdog finds nothing to
stop and Ray's own clean-up is all there is.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import Self

OWNER_ENV = "SLT_RAY_OWNER"
"""Environment variable whose value marks the processes of one watched Ray instance."""

GRACE_S = 2.0
"""Seconds the marked processes get to exit on SIGTERM before the SIGKILLs."""

SWEEP_LIMIT_S = 30.0
"""Seconds after which the watchdog gives up on processes that do not die (not expected)."""

POLL_S = 0.2
"""Seconds between looks for the instance's node id while it starts."""

PROC = Path("/proc")


class Instance:
    """What identifies the processes of one watched Ray instance.

    Args:
        token: The mark in the environment of the processes started inside
            :meth:`RayWatchdog.marking`.
        driver: The driver's process id: never part of the instance, although it holds files
            of the session open (its own Ray logs).
    """

    def __init__(self, token: str, driver: int | None = None) -> None:
        self.mark = f"{OWNER_ENV}={token}".encode()
        self.driver = driver
        self.nodes: set[bytes] = set()
        self.sessions: set[bytes] = set()

    def learn(self, proc: Path = PROC) -> bool:
        """Read the node id and session folder off the marked processes' command lines.

        The GCS server, the first process of an instance, is started with ``--node-id=<id>``
        and ``--session-dir=<dir>``. The agents the raylet starts later lack the mark, and
        ``setproctitle`` may blank their ``/proc/<pid>/environ``; they are found by the session
        folder their logs are open in. Returns whether both are known.
        """
        for _, env, cmdline in _live_processes(proc):
            if self.mark in env:
                for arg in cmdline:
                    key, sep, value = arg.partition(b"=")
                    if not sep or not value:
                        continue
                    if key in (b"--node-id", b"--node_id"):
                        self.nodes.add(value)
                    elif key in (b"--session-dir", b"--session_dir"):
                        self.sessions.add(value.rstrip(b"/") + b"/")
        return bool(self.nodes and self.sessions)

    def owns(self, pid: int, env: list[bytes], cmdline: list[bytes], proc: Path = PROC) -> bool:
        """Whether process ``pid`` belongs to the instance (mark, node id or session folder)."""
        if self.mark in env or any(b"RAY_NODE_ID=" + n in env for n in self.nodes):
            return True
        if not self.sessions or not _is_ray(cmdline):
            return False  # e.g. a user's `tail -f` on a log of the session is not Ray's
        if any(session in arg for arg in cmdline for session in self.sessions):
            return True
        try:
            fds = list((proc / str(pid) / "fd").iterdir())
        except OSError:
            return False
        for fd in fds:
            try:
                target = os.fsencode(fd.readlink())
            except OSError:
                continue
            if target.startswith(tuple(self.sessions)):
                return True
        return False

    def pids(self, proc: Path = PROC) -> list[int]:
        """Return the live processes of the instance."""
        return [
            pid
            for pid, env, cmd in _live_processes(proc)
            if pid != self.driver and self.owns(pid, env, cmd, proc)
        ]


def _is_ray(cmdline: list[bytes]) -> bool:
    """Whether a command line is a Ray process's: a ``ray::`` title or a program of Ray's."""
    return cmdline[0].startswith(b"ray::") or any(b"/ray/" in arg for arg in cmdline[:2])


def _stat_fields(pid: int | str, proc: Path = PROC) -> list[bytes]:
    """Return the fields of ``/proc/<pid>/stat`` after the command name (state first)."""
    return (proc / str(pid) / "stat").read_bytes().rpartition(b")")[2].split()


def alive(pid: int, proc: Path = PROC) -> bool:
    """Whether process ``pid`` runs (a zombie is dead, only not yet reaped by its parent)."""
    try:
        return _stat_fields(pid, proc)[0] not in (b"Z", b"X")
    except (OSError, IndexError):
        return False


def descendants(root: int, proc: Path = PROC) -> list[int]:
    """Return the processes below ``root`` in the process tree."""
    children: dict[int, list[int]] = {}
    for entry in proc.iterdir():
        if entry.name.isdigit():
            try:
                ppid = int(_stat_fields(entry.name, proc)[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(entry.name))
    found, todo = [], [root]
    while todo:
        kids = children.get(todo.pop(), [])
        found += kids
        todo += kids
    return found


def _live_processes(proc: Path) -> Iterator[tuple[int, list[bytes], list[bytes]]]:
    """Yield ``(pid, environment, command line)`` of the readable, live processes but this one.

    Processes of other users, ones that exit while being read and zombies (dead, only not yet
    reaped by their parent) are skipped.
    """
    try:
        entries = list(proc.iterdir())
    except OSError:  # no /proc: not Linux
        return
    me = str(os.getpid())
    for entry in entries:
        if not entry.name.isdigit() or entry.name == me:
            continue
        try:
            env = (entry / "environ").read_bytes().split(b"\0")
            cmdline = (entry / "cmdline").read_bytes().split(b"\0")
            state = _stat_fields(entry.name, proc)[0]
        except (OSError, IndexError):
            continue
        if state not in (b"Z", b"X"):
            yield int(entry.name), env, cmdline


def sweep(instance: Instance, grace_s: float = GRACE_S, limit_s: float = SWEEP_LIMIT_S) -> int:
    """Stop every process of ``instance``; return how many were signalled.

    Repeats until a scan finds none, as a dying raylet may still start a worker: SIGTERM for
    ``grace_s``, then SIGKILL, for at most ``limit_s``.
    """
    start = time.monotonic()
    signalled: set[int] = set()
    while True:
        instance.learn()
        pids = instance.pids()
        elapsed = time.monotonic() - start
        if not pids or elapsed > limit_s:
            return len(signalled)
        sig = signal.SIGTERM if elapsed < grace_s else signal.SIGKILL
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, sig)
        signalled.update(pids)
        time.sleep(0.05)


def watch(token: str, driver: int, driver_fd: int) -> int:
    """Wait until the pipe from ``driver`` closes, then sweep; return how many were signalled.

    While waiting, the instance's node id and session folder are read off its GCS server's
    command line (polled until found), while it is still there to be read.
    """
    # The driver's Ctrl-C or hang-up is the driver's to handle; the pipe says when it is gone.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    instance = Instance(token, driver)
    known = False
    while True:
        try:
            ready, _, _ = select.select([driver_fd], [], [], None if known else POLL_S)
            if ready and not os.read(driver_fd, 4096):
                break
        except OSError:
            break
        if not ready:
            known = instance.learn()
    return sweep(instance)


class RayWatchdog:
    """Driver side: start the watchdog process, mark the Ray processes, stop them at the end.

    Use as a context manager around the whole life of a locally started Ray instance, and start
    the instance inside :meth:`marking`::

        with RayWatchdog() as dog:
            with dog.marking():
                ray.init(...)
            ...
            ray.shutdown()
    """

    def __init__(self) -> None:
        self.token = secrets.token_hex(16)
        self._proc: subprocess.Popen[bytes] | None = None

    def __enter__(self) -> Self:
        self._proc = subprocess.Popen(
            [sys.executable, "-I", "-S", str(Path(__file__)), self.token, str(os.getpid())],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,  # outlives a kill of the driver's process group
        )
        return self

    @contextlib.contextmanager
    def marking(self) -> Iterator[None]:
        """Mark the processes started inside the block (they inherit ``SLT_RAY_OWNER``)."""
        before = os.environ.get(OWNER_ENV)
        os.environ[OWNER_ENV] = self.token
        try:
            yield
        finally:
            if before is None:
                del os.environ[OWNER_ENV]
            else:
                os.environ[OWNER_ENV] = before

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Close the pipe and wait for the sweep, so nothing of the instance outlives the batch."""
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.stdin is not None:
            proc.stdin.close()
        try:
            proc.wait(timeout=SWEEP_LIMIT_S + 5)
        except subprocess.TimeoutExpired:  # not expected; never block the batch on it
            proc.kill()
            proc.wait()


if __name__ == "__main__":
    watch(sys.argv[1], int(sys.argv[2]), sys.stdin.fileno())
