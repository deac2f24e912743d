"""The run layout: one path per output of a run, and what makes a folder a reprocess run."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.reporting import run_layout
from superlane_tools.reporting.run_layout import (
    DERIVED_SCHEMAS,
    DERIVED_TABLES,
    STREAMED_SCHEMAS,
    STREAMED_TABLES,
    RunLayout,
    is_reprocess_run,
)


def test_layout_paths_are_under_the_root_and_distinct(tmp_path: Path) -> None:
    layout = RunLayout(tmp_path)
    tables = {**layout.streamed(), **layout.derived()}
    assert list(tables) == [*STREAMED_TABLES, *DERIVED_TABLES]
    assert set(STREAMED_SCHEMAS) == set(STREAMED_TABLES)
    assert list(DERIVED_SCHEMAS) == list(DERIVED_TABLES)
    paths = [*tables.values(), layout.annotations, layout.overlay, layout.report, layout.plots]
    assert len(set(paths)) == len(paths)
    assert all(p.parent == tmp_path for p in paths)
    assert layout.lanes == tmp_path / run_layout.LANES_FILE
    assert RunLayout(str(tmp_path)).root == tmp_path  # str roots are paths too
    with pytest.raises(KeyError, match="not a table"):
        layout.table("report")


def test_is_reprocess_run_needs_the_manifest_tables_and_report(tmp_path: Path) -> None:
    layout = RunLayout(tmp_path / "run")
    assert not is_reprocess_run(layout.root)  # missing
    layout.root.mkdir()
    for path in (layout.availability_sequences, layout.report):
        path.write_bytes(b"x")
    assert not is_reprocess_run(layout.root)  # no manifest: killed or foreign
    layout.manifest.write_text("{}")
    assert is_reprocess_run(layout.root)
    layout.report.unlink()
    assert not is_reprocess_run(layout.root)
