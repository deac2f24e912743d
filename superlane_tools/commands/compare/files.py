"""File names ``slt compare`` reads (a reprocess run, a batch root) and writes."""

from __future__ import annotations

from superlane_tools.fleet import RunFiles

RUN_FILES = RunFiles(
    tables={
        "availability_frames": "availability_frames.parquet",
        "availability_sequences": "availability_sequences.parquet",
        "curvature": "curvature.parquet",
        "lanes": "lanes.parquet",
        "frames": "frames.parquet",
    },
    annotations="annotations.mcap",
    batch_status="batch_status.parquet",
)
COMPARE_TABLE = "compare.parquet"
SPANS_TABLE = "compare_spans.parquet"
DRIVES_TABLE = "compare_drives.parquet"
REPORT = "compare.md"
PLOTS = "plots"
