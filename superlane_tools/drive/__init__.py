"""One drive through the reprocess stages: per-frame stages, the typed record, the drive tables."""

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
    load_manifest,
)
from superlane_tools.drive.finalize import DriveTables, drive_tables
from superlane_tools.drive.record import Corridors, DriveFrames, DriveRecorder, FitSeries
from superlane_tools.drive.stages import Finished, FrameStages, Prepared
from superlane_tools.reporting.drive_sections import ReportFacts

__all__ = [
    "BACKENDS",
    "CanConfig",
    "CorridorConfig",
    "Corridors",
    "DriveFrames",
    "DriveRecorder",
    "DriveTables",
    "Finished",
    "FitSeries",
    "FrameStages",
    "KpiConfig",
    "OutputConfig",
    "Prepared",
    "ReportFacts",
    "ReprocessConfig",
    "RtkConfig",
    "SegmentationConfig",
    "TopicsConfig",
    "TrackingConfig",
    "config_from_mapping",
    "default_config_yaml",
    "drive_tables",
    "load_config",
    "load_manifest",
]
