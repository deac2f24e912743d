"""The writer of ``slt reprocess``: the derived tables, the plots and the report, by file name."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.finalize import DriveTables, report_sections
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.drive_sections import ReportFacts
from superlane_tools.reporting.plots import ExampleFrame
from superlane_tools.reporting.report import write_report

if TYPE_CHECKING:
    import pandas as pd

STREAMED_FILES = {
    "frames": "frames.parquet",
    "lanes": "lanes.parquet",
    "corridor": "corridor.parquet",
    "baseline": "baseline.parquet",
}
"""Table -> file name of the tables written while the frames stream."""


def streamed_files(out: Path) -> dict[str, Path]:
    """Return the paths of the streamed tables under ``out``."""
    return {table: out / name for table, name in STREAMED_FILES.items()}


def table_files(result: DriveTables) -> dict[str, pd.DataFrame]:
    """Return output file name -> table."""
    return {
        "can_signals.parquet": result.can_signals,
        "mobileye.parquet": result.mobileye,
        "rtk.parquet": result.rtk,
        "curvature.parquet": result.curvature,
        "curvature_summary.parquet": result.curvature_summary,
        "availability_frames.parquet": result.availability_frames,
        "availability_sequences.parquet": result.availability_sequences,
    }


def write_outputs(
    out: Path,
    result: DriveTables,
    provenance: Provenance,
    config: ReprocessConfig,
    examples: Sequence[ExampleFrame],
    report: ReportFacts,
    rendered: Sequence[Path] = (),
) -> list[Path]:
    """Write the derived tables, the plots and the report; return the files written.

    ``rendered``: example plots already written (during the pass), listed after the plots
    drawn here, as :func:`~superlane_tools.reporting.plots.plot_all` orders its own examples.
    """
    written = [write_table(t, out / name, provenance) for name, t in table_files(result).items()]
    images: list[str] = []
    if config.output.plots:
        from superlane_tools.reporting.plots import plot_all

        pngs = plot_all(result.curvature, result.availability_frames, examples, out / "plots")
        pngs += rendered
        written += pngs
        images = [p.relative_to(out).as_posix() for p in pngs]
    written += write_report(
        out / "report.md",
        f"slt reprocess: {report.recording.name}",
        report_sections(config, report, result, images),
    )
    return written
