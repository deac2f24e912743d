"""The output layout: one TableSpec per table, one path per output, what makes a run folder."""

from __future__ import annotations

import copy
import pickle
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pytest

from superlane_tools.reporting.layout import (
    DERIVED_SCHEMAS,
    DERIVED_TABLES,
    LANES_TABLE,
    MINE_MANIFEST_TABLE,
    STREAMED_SCHEMAS,
    STREAMED_TABLES,
    TABLES,
    CompareLayout,
    ExtractLayout,
    RunLayout,
    SchemaMismatchError,
    checked_table,
    is_reprocess_run,
    tables_of,
)
from superlane_tools.reporting.layout.tables import _table


def test_layout_paths_are_under_the_root_and_distinct(tmp_path: Path) -> None:
    layout = RunLayout(tmp_path)
    tables = {**layout.streamed(), **layout.derived()}
    assert list(tables) == [*STREAMED_TABLES, *DERIVED_TABLES]
    assert set(STREAMED_SCHEMAS) == set(STREAMED_TABLES)
    assert list(DERIVED_SCHEMAS) == list(DERIVED_TABLES)
    paths = [*tables.values(), layout.annotations, layout.overlay, layout.report, layout.plots]
    assert len(set(paths)) == len(paths)
    assert all(p.parent == tmp_path for p in paths)
    assert layout.lanes == tmp_path / LANES_TABLE.file
    assert RunLayout(str(tmp_path)).root == tmp_path  # str roots are paths too
    with pytest.raises(KeyError, match="not a table"):
        layout.table("report")


def test_every_table_is_an_attribute_of_its_folder_by_name(tmp_path: Path) -> None:
    """The layouts' table attributes come from the specs: a new spec is a new attribute."""
    assert list(tables_of("streamed")) == list(STREAMED_TABLES)
    for spec in TABLES:
        if spec.stage in RunLayout.STAGES:
            assert getattr(RunLayout(tmp_path), spec.name) == tmp_path / spec.file
    assert ExtractLayout(tmp_path).camera_info == tmp_path / "camera_info.parquet"
    assert CompareLayout(tmp_path).spans == tmp_path / "compare_spans.parquet"
    with pytest.raises(AttributeError, match="no table or file 'camera_info'"):
        _ = RunLayout(tmp_path).camera_info  # extract's table, not a run's
    files = [(t.stage, t.file) for t in TABLES]
    assert len(set(files)) == len(files)
    layout = RunLayout(tmp_path)
    for same in (copy.copy(layout), copy.deepcopy(layout), pickle.loads(pickle.dumps(layout))):
        assert same == layout
        assert same.lanes == layout.lanes  # generated attributes survive copies (batch workers)


def test_a_table_is_declared_once_per_stage() -> None:
    with pytest.raises(ValueError, match="declared twice"):
        _table("streamed", "lanes", "other_lanes.parquet", LANES_TABLE.schema)
    assert sum(t.name == "lanes" for t in TABLES) == 1


def test_readers_pick_only_declared_columns() -> None:
    assert LANES_TABLE.pick("frame_index", "cost") == ("frame_index", "cost")
    with pytest.raises(KeyError, match=r"lanes\.parquet declares no column"):
        LANES_TABLE.pick("frame_index", "no_such_column")


def test_a_table_is_checked_against_its_spec() -> None:
    row = {
        "drive": "d",
        "recording": "r.mcap",
        "image": "images/d_000001.jpg",
        "frame_index": 1,
        "log_time_ns": 5,
        "width": 640,
        "height": 480,
        "reasons": "disagree",
        "score": 0.5,
        "disagree": 0.5,
    }
    table = checked_table(MINE_MANIFEST_TABLE, pd.DataFrame([row]))
    assert table.num_rows == 1
    assert checked_table(MINE_MANIFEST_TABLE, pd.DataFrame([])).num_columns == 0  # nothing picked
    with pytest.raises(SchemaMismatchError, match="undeclared columns"):
        checked_table(MINE_MANIFEST_TABLE, pd.DataFrame([{**row, "extra": 1}]))
    with pytest.raises(SchemaMismatchError, match="width is string"):
        checked_table(MINE_MANIFEST_TABLE, pa.Table.from_pylist([{**row, "width": "640"}]))


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
