"""``slt reprocess``: the end-to-end offline pipeline from a drive to tables, plots and reports.

Its configuration lives in the drive layer (:mod:`superlane_tools.drive.config`), imported from
there only.

The names below load their module on first use (PEP 562), so that ``slt reprocess`` starts the
lane-fit kernels' compiler (:mod:`superlane_tools.commands.reprocess.entry`) before the
pipeline's imports, as it did from ``cli/``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from superlane_tools._lazy import lazy_attributes

if TYPE_CHECKING:
    from superlane_tools.commands.reprocess.publish import reprocess_run
    from superlane_tools.commands.reprocess.result import ReprocessResult
    from superlane_tools.commands.reprocess.run import reprocess

_HOMES = {
    "ReprocessResult": "superlane_tools.commands.reprocess.result",
    "reprocess": "superlane_tools.commands.reprocess.run",
    "reprocess_run": "superlane_tools.commands.reprocess.publish",
}


__getattr__ = lazy_attributes(__name__, globals(), _HOMES)


__all__ = [
    "ReprocessResult",
    "reprocess",
    "reprocess_run",
]
