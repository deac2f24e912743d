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
from superlane_tools.drive.finalize import DerivedTables, drive_tables
from superlane_tools.drive.loop import (
    DrivePass,
    DriveTopics,
    FrameSink,
    drive_topics,
    frame_total,
    run_frames,
)
from superlane_tools.drive.record import Corridors, DriveFrames, DriveFramesBuilder, FitSeries
from superlane_tools.drive.reprocess_pass import DriveOutcome, PassSetup, reprocess_pass
from superlane_tools.drive.sinks import AnnotationSink, ExampleSink, FrameTablesSink, VideoSink
from superlane_tools.drive.stages import Finished, FrameStages, Prepared
from superlane_tools.reporting.drive_sections import ReportFacts

__all__ = [
    "BACKENDS",
    "AnnotationSink",
    "CanConfig",
    "CorridorConfig",
    "Corridors",
    "DerivedTables",
    "DriveFrames",
    "DriveFramesBuilder",
    "DriveOutcome",
    "DrivePass",
    "DriveTopics",
    "ExampleSink",
    "Finished",
    "FitSeries",
    "FrameSink",
    "FrameStages",
    "FrameTablesSink",
    "KpiConfig",
    "OutputConfig",
    "PassSetup",
    "Prepared",
    "ReportFacts",
    "ReprocessConfig",
    "RtkConfig",
    "SegmentationConfig",
    "TopicsConfig",
    "TrackingConfig",
    "VideoSink",
    "config_from_mapping",
    "default_config_yaml",
    "drive_tables",
    "drive_topics",
    "frame_total",
    "load_config",
    "load_manifest",
    "reprocess_pass",
    "run_frames",
]
