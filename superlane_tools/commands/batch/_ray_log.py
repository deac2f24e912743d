"""Send the Ray driver's own messages to a log file, so ``slt batch``'s output stays its own.

A Ray driver prints what the cluster reports (a node marked dead with the last 20 lines of its
raylet's log, a worker that died, autoscaler events) on ``sys.stdout``, from a background
thread, even with ``log_to_driver=False`` (which silences only the workers' own output), and
the ``ray`` loggers write warnings to stderr. Inside :func:`ray_log`, both go to one
file instead: ``ROOT/batch_ray.log``, appended to, one header line per batch.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

RAY_LOG_FILE = "batch_ray.log"
"""The log of Ray's messages under the output root."""

_RAY_LOGGERS = ("ray",)


class RayLog:
    """Ray's driver-side messages, written to one file; count the lines written.

    Args:
        path: The log file (appended to; its folder must exist).
        file: The open file.
    """

    def __init__(self, path: Path, file: IO[str]) -> None:
        self.path = path
        self.lines = 0
        self._file = file

    def write(self, text: str) -> None:
        """Append ``text`` (one or more lines) to the log and flush it."""
        for line in text.splitlines():
            self._file.write(line + "\n")
            self.lines += 1
        self._file.flush()

    def print_to_stdstream(self, data: dict[str, Any], ignore_prefix: bool = False) -> None:  # noqa: ARG002 (Ray's signature)
        """Ray's ``print_to_stdstream``: ``data`` holds ``lines`` from a ``pid`` (``raylet``...)."""
        source = data.get("pid", "")
        stamp = time.strftime("%H:%M:%S")
        self.write("\n".join(f"{stamp} ({source}) {line}" for line in data.get("lines", [])))


@contextlib.contextmanager
def ray_log(path: Path) -> Iterator[RayLog]:
    """Route Ray's driver-side messages and the ``ray`` loggers to ``path`` inside the block."""
    # Where the driver prints them (Ray 2.60; a Ray without it keeps printing them itself).
    ray_worker: Any = importlib.import_module("ray._private.worker")
    patch = hasattr(ray_worker, "print_to_stdstream")
    with path.open("a", encoding="utf-8") as file:
        stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        file.write(f"== slt batch {stamp}: Ray's messages follow\n")
        file.flush()
        log = RayLog(path, file)
        handler = logging.StreamHandler(file)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        saved_print = getattr(ray_worker, "print_to_stdstream", None)
        saved = [(logger, list(logger.handlers), logger.propagate) for logger in _loggers()]
        if patch:
            ray_worker.print_to_stdstream = log.print_to_stdstream
        for logger, _, _ in saved:
            logger.handlers = [handler]
            logger.propagate = False
        try:
            yield log
        finally:
            if patch:
                ray_worker.print_to_stdstream = saved_print
            for logger, handlers, propagate in saved:
                logger.handlers = handlers
                logger.propagate = propagate


def _loggers() -> list[logging.Logger]:
    return [logging.getLogger(name) for name in _RAY_LOGGERS]
