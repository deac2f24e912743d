"""``slt reprocess``: the end-to-end offline pipeline from a drive to tables, plots and reports.

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
    from superlane_tools.drive.config import (
        BACKENDS,
        CanConfig,
        CorridorConfig,
        KpiConfig,
        OutputConfig,
        ReprocessConfig,
        RtkConfig,
        SegmentationConfig,
        TopicsConfig,
        TrackingConfig,
        config_from_mapping,
        default_config_yaml,
        load_config,
    )

_HOMES = {
    "BACKENDS": "superlane_tools.drive.config",
    "CanConfig": "superlane_tools.drive.config",
    "CorridorConfig": "superlane_tools.drive.config",
    "KpiConfig": "superlane_tools.drive.config",
    "OutputConfig": "superlane_tools.drive.config",
    "ReprocessConfig": "superlane_tools.drive.config",
    "ReprocessResult": "superlane_tools.commands.reprocess.result",
    "RtkConfig": "superlane_tools.drive.config",
    "SegmentationConfig": "superlane_tools.drive.config",
    "TopicsConfig": "superlane_tools.drive.config",
    "TrackingConfig": "superlane_tools.drive.config",
    "config_from_mapping": "superlane_tools.drive.config",
    "default_config_yaml": "superlane_tools.drive.config",
    "load_config": "superlane_tools.drive.config",
    "reprocess": "superlane_tools.commands.reprocess.run",
    "reprocess_run": "superlane_tools.commands.reprocess.publish",
}


__getattr__ = lazy_attributes(__name__, globals(), _HOMES)


__all__ = [
    "BACKENDS",
    "CanConfig",
    "CorridorConfig",
    "KpiConfig",
    "OutputConfig",
    "ReprocessConfig",
    "ReprocessResult",
    "RtkConfig",
    "SegmentationConfig",
    "TopicsConfig",
    "TrackingConfig",
    "config_from_mapping",
    "default_config_yaml",
    "load_config",
    "reprocess",
    "reprocess_run",
]
