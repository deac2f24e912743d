"""The writer of ``slt reprocess``: the derived tables, the plots and the report."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.finalize import DriveTables, ReportFacts, report_sections
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.plots import ExampleFrame
from superlane_tools.reporting.report import write_report
from superlane_tools.reporting.run_layout import RunLayout

if TYPE_CHECKING:
    import pandas as pd


def table_files(out: Path, result: DriveTables) -> dict[Path, pd.DataFrame]:
    """Return output path -> table of the derived tables (named by :class:`RunLayout`)."""
    return {path: getattr(result, name) for name, path in RunLayout(out).derived().items()}


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
    layout = RunLayout(out)
    written = [write_table(t, path, provenance) for path, t in table_files(out, result).items()]
    images: list[str] = []
    if config.output.plots:
        from superlane_tools.reporting.plots import plot_all

        pngs = plot_all(result.curvature, result.availability_frames, examples, layout.plots)
        pngs += rendered
        written += pngs
        images = [p.relative_to(out).as_posix() for p in pngs]
    written += write_report(
        layout.report,
        f"slt reprocess: {report.recording.name}",
        report_sections(config, report, result, images),
    )
    return written
