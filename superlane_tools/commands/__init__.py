"""Pipelines that wire recordings, decoding and stages together (extract, reprocess)."""

from superlane_tools.pipeline.errors import PipelineError
from superlane_tools.pipeline.extract import (
    FRAME_FORMATS,
    STREAM_KINDS,
    ExtractConfig,
    ExtractResult,
    extract,
    load_stream_config,
    select_streams,
)

__all__ = [
    "FRAME_FORMATS",
    "STREAM_KINDS",
    "ExtractConfig",
    "ExtractResult",
    "PipelineError",
    "extract",
    "load_stream_config",
    "select_streams",
]
