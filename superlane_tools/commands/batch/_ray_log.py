"""Send the Ray driver's own messages to a log file, so ``slt batch``'s output stays its own.

A Ray driver prints what the cluster reports (a node marked dead with the last 20 lines of its
raylet's log, a worker that died, autoscaler events) on ``sys.stdout``, from a background
thread, even with ``log_to_driver=False`` (which silences only the workers' own output), and
the ``ray`` loggers write warnings to stderr. While :class:`RayLog` is entered, both go to one
file instead: ``ROOT/batch_ray.log``, appended to, one header line per batch.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Self

RAY_LOG_FILE = "batch_ray.log"
"""The log of Ray's messages under the output root."""

_RAY_LOGGERS = ("ray",)


class RayLog:
    """Route Ray's driver-side messages to ``path`` while entered; count the lines written.

    Args:
        path: The log file (appended to; its folder must exist).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.lines = 0
        self._file: IO[str] | None = None
        self._saved_print: Any = None
        self._handler: logging.Handler | None = None
        self._saved_loggers: list[tuple[logging.Logger, list[logging.Handler], bool]] = []

    def write(self, text: str) -> None:
        """Append ``text`` (one or more lines) to the log and flush it."""
        if self._file is None:
            return
        for line in text.splitlines():
            self._file.write(line + "\n")
            self.lines += 1
        self._file.flush()

    def __enter__(self) -> Self:
        self._file = self.path.open("a", encoding="utf-8")
        stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        self._file.write(f"== slt batch {stamp}: Ray's messages follow\n")
        self._file.flush()
        from ray._private import worker as ray_worker  # where the driver prints them

        self._saved_print = ray_worker.print_to_stdstream
        ray_worker.print_to_stdstream = self._print_to_stdstream
        self._handler = logging.StreamHandler(self._file)
        self._handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        for name in _RAY_LOGGERS:
            logger = logging.getLogger(name)
            self._saved_loggers.append((logger, list(logger.handlers), logger.propagate))
            logger.handlers = [self._handler]
            logger.propagate = False
        return self

    def _print_to_stdstream(self, data: dict[str, Any], ignore_prefix: bool = False) -> None:  # noqa: ARG002 (Ray's signature)
        """Ray's ``print_to_stdstream``: ``data`` holds ``lines`` from a ``pid`` (``raylet``...)."""
        source = data.get("pid", "")
        stamp = time.strftime("%H:%M:%S")
        self.write("\n".join(f"{stamp} ({source}) {line}" for line in data.get("lines", [])))

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Restore Ray's printing and loggers, close the file."""
        if self._saved_print is not None:
            from ray._private import worker as ray_worker

            ray_worker.print_to_stdstream = self._saved_print
            self._saved_print = None
        for logger, handlers, propagate in self._saved_loggers:
            logger.handlers = handlers
            logger.propagate = propagate
        self._saved_loggers.clear()
        if self._file is not None:
            self._file.close()
            self._file = None
