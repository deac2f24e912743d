"""``slt reprocess``: the end-to-end offline pipeline from a drive to tables, plots and reports."""

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
