"""The reporting layer on its own: the report writer, Markdown tables, atomic files, Parquet."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pytest

from superlane_tools.reporting import (
    ParquetStreamWriter,
    Provenance,
    read_provenance,
    write_table,
    write_text_atomic,
)
from superlane_tools.reporting.report import Section, markdown_table, write_report


def test_markdown_table_formats_floats_and_missing_values() -> None:
    frame = pd.DataFrame({"name": ["a", "b"], "value": [0.123456, math.nan], "n": [3, 40000]})
    lines = markdown_table(frame).splitlines()
    assert lines[0] == "| name | value | n |"
    assert lines[1] == "|---|---|---|"
    assert lines[2] == "| a | 0.123 | 3 |"
    assert lines[3] == "| b | n/a | 40000 |"


def test_write_report_writes_markdown_and_html_at_the_given_path(tmp_path: Path) -> None:
    sections = [
        Section(
            "Run",
            ["- frames: 3", "A <b> paragraph", "**Inputs:** `camera`"],
            [pd.DataFrame({"x": [1.5]})],
        ),
        Section("Plots", (), (), ["plots/a.png"]),
    ]
    written = write_report(tmp_path / "out" / "summary.md", "Title & more", sections)
    assert written == [tmp_path / "out" / "summary.md", tmp_path / "out" / "summary.html"]
    md = written[0].read_text(encoding="utf-8")
    assert md.startswith("# Title & more\n")
    assert "## Run" in md
    assert "| 1.500 |" in md
    assert "![a](plots/a.png)" in md
    page = written[1].read_text(encoding="utf-8")
    assert "<li>frames: 3</li>" in page
    assert "A &lt;b&gt; paragraph" in page  # escaped
    assert "<p><b>Inputs:</b> <code>camera</code></p>" in page  # Markdown bold and code
    assert "<img src='plots/a.png'" in page
    assert not list((tmp_path / "out").glob(".*tmp*"))
    only_md = write_report(tmp_path / "r.md", "t", sections, html_too=False)
    assert only_md == [tmp_path / "r.md"]


def test_atomic_text_replaces_whole_files(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b.txt"
    write_text_atomic(target, "first")
    write_text_atomic(target, "second")
    assert target.read_text(encoding="utf-8") == "second"
    assert sorted(p.name for p in target.parent.iterdir()) == ["b.txt"]


def test_parquet_carries_provenance_and_a_failed_stream_leaves_nothing(tmp_path: Path) -> None:
    prov = Provenance(command="slt test", config={"k": 1})
    path = write_table(pd.DataFrame({"x": [1, 2]}), tmp_path / "t.parquet", prov)
    meta = read_provenance(path)
    assert meta["command"] == "slt test"
    assert meta["config"] == {"k": 1}
    schema = pa.schema([("x", pa.int64())])
    target = tmp_path / "s.parquet"

    def fail_midway() -> None:
        with ParquetStreamWriter(target, schema, prov) as writer:
            writer.write(pa.table({"x": [1]}, schema=schema))
            raise RuntimeError("stage failed")

    with pytest.raises(RuntimeError, match="stage failed"):
        fail_midway()
    assert not target.exists()
    assert not list(tmp_path.glob(".*tmp*"))
