"""The names of every output file and folder that is not a table (tables: :mod:`.tables`)."""

from __future__ import annotations

# ---- a reprocess run ----------------------------------------------------------------------
ANNOTATIONS_FILE = "annotations.mcap"
OVERLAY_FILE = "overlay.mp4"
REPORT_FILE = "report.md"
"""The report; ``report.html`` (:data:`REPORT_HTML_FILE`) is written beside it."""
REPORT_HTML_FILE = "report.html"
PLOTS_DIR = "plots"
"""Folder of the plots: the ``*_PLOT`` files and :func:`example_plot_name`."""
CURVATURE_TIME_PLOT = "curvature_time.png"
CURVATURE_DISTANCE_PLOT = "curvature_distance.png"
AVAILABILITY_PLOT = "availability_timeline.png"
MANIFEST_FILE = "run_manifest.json"
"""Written last: a run folder without it is incomplete (see :mod:`..run_folder`)."""

# ---- slt batch and pipelines/nightly.py ---------------------------------------------------
SUMMARY_DIR = "summary"
"""``slt batch``'s fleet summary folder under the output root."""
NIGHTLY_COMPARE_DIR = "compare"
"""``pipelines/nightly.py --baseline``: the comparison with the baseline, under the summary."""
NIGHTLY_MINED_DIR = "mined"
"""``pipelines/nightly.py --baseline``: the frames worth labelling, under the summary."""
NIGHTLY_STATE_FILE = "nightly_state.json"
"""``pipelines/nightly.py``: what the last night did, at the output root."""

# ---- slt compare and slt mine -------------------------------------------------------------
COMPARE_REPORT_FILE = "compare.md"
"""The comparison report; ``compare.html`` is written beside it."""
COMPARE_DELTAS_PLOT = "deltas.png"
MINE_IMAGES_DIR = "images"
TUSIMPLE_LABELS_FILE = "labels.json"
"""A TuSimple label folder's label lines (``slt mine`` writes it, ``slt train`` reads it)."""

# ---- the fleet's history (pipelines/nightly.py appends, slt history reads) ---------------------
HISTORY_DIR = "history"
"""The partitioned Parquet dataset of nightly KPIs under a nightly root (``night=DATE/``)."""
HISTORY_REPORT_FILE = "history.md"
"""``slt history``'s page; ``history.html`` is written beside it."""
HISTORY_PARTITION = "night"
"""The dataset's hive partition key: the night, ``YYYY-MM-DD``."""


def example_plot_name(frame_index: int) -> str:
    """Return the file name (under :data:`PLOTS_DIR`) of a frame's example plot."""
    return f"example_{frame_index:06d}.png"
