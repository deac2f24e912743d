"""Batch inputs: folder discovery, manifests (CSV, Parquet, YAML), recording ids, units."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest

from superlane_tools.commands.batch import (
    BatchEntry,
    expand_inputs,
    find_recordings,
    read_manifest,
    recording_id,
)
from superlane_tools.commands.batch.plan import job_units
from superlane_tools.errors import ConfigError, UsageError

CANDUMP = "(1700000000.000000) can0 100#0102030405060708\n(1700000000.010000) can0 100#01\n"


def _tree(root: Path, write_drive: Callable[..., Path]) -> None:
    (root / "a" / "b").mkdir(parents=True)
    write_drive(root / "a" / "one.mcap", seed=1)
    write_drive(root / "a" / "b" / "two.bag", seed=2, fmt="ros1")
    write_drive(root / "a" / "b" / "bag2", seed=3, fmt="ros2")
    (root / "a" / "b" / "bus.log").write_text(CANDUMP)
    (root / "a" / "notes.log").write_text("just some text\n")
    (root / "a" / "readme.txt").write_text("x")
    (root / ".tmp").mkdir()
    write_drive(root / ".tmp" / "hidden.mcap", seed=4)


def test_find_recordings_recursive(tmp_path: Path, write_drive: Callable[..., Path]) -> None:
    _tree(tmp_path, write_drive)
    found = [p.relative_to(tmp_path).as_posix() for p in find_recordings(tmp_path)]
    assert found == ["a/b/bag2", "a/b/bus.log", "a/b/two.bag", "a/one.mcap"]


def test_expand_inputs(tmp_path: Path, write_drive: Callable[..., Path]) -> None:
    _tree(tmp_path, write_drive)
    entries = expand_inputs([tmp_path / "a" / "one.mcap", tmp_path / "a" / "b"])
    assert [e.path.name for e in entries] == ["one.mcap", "bag2", "bus.log", "two.bag"]
    with pytest.raises(UsageError, match="does not exist"):
        expand_inputs([tmp_path / "missing.mcap"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(UsageError, match="no recordings found"):
        expand_inputs([tmp_path / "empty"])


def test_manifest_csv_parquet_yaml(tmp_path: Path, write_drive: Callable[..., Path]) -> None:
    write_drive(tmp_path / "d1.mcap", seed=1)
    rows = [
        {
            "path": "d1.mcap",
            "category": "highway",
            "vehicle": "car7",
            "date": "2024-05-01",
            "sequence": "s1",
            "start_s": "0",
            "end_s": "0.5",
        },
        {
            "path": str(tmp_path / "d1.mcap"),
            "category": "city",
            "vehicle": "",
            "date": "",
            "sequence": "",
            "start_s": "",
            "end_s": "",
        },
    ]
    pd.DataFrame(rows).to_csv(tmp_path / "m.csv", index=False)
    frame = pd.DataFrame(rows).replace("", None)
    frame.to_parquet(tmp_path / "m.parquet")
    (tmp_path / "m.yaml").write_text(
        "recordings:\n"
        "  - {path: d1.mcap, category: highway, vehicle: car7, date: '2024-05-01',"
        " sequence: s1, start_s: 0, end_s: 0.5}\n"
        f"  - {{path: {tmp_path / 'd1.mcap'}, category: city}}\n"
    )
    for name in ("m.csv", "m.parquet", "m.yaml"):
        first, second = read_manifest(tmp_path / name)
        assert first == BatchEntry(
            tmp_path / "d1.mcap", "highway", "car7", "2024-05-01", "s1", 0.0, 0.5
        ), name
        assert second == BatchEntry(tmp_path / "d1.mcap", "city"), name


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("category\nhighway\n", "missing path"),
        ("path,colour\nx.mcap,red\n", "unknown columns"),
        ("path,start_s,end_s\nx.mcap,5,2\n", "must be after"),
        ("path,start_s\nx.mcap,soon\n", "number of seconds"),
        ("path\n", "lists no recordings"),
    ],
)
def test_manifest_errors(tmp_path: Path, text: str, match: str) -> None:
    (tmp_path / "m.csv").write_text(text)
    with pytest.raises(ConfigError, match=match):
        read_manifest(tmp_path / "m.csv")


@pytest.mark.parametrize(
    ("yaml", "match"),
    [
        ("- path: [a.mcap]\n", r"row 1: path must be one recording path \(text\), not a list"),
        ("- a.mcap\n- path: {x: 1}\n", "row 2: path must be one recording path.*a mapping"),
        ("- path: 7\n", "row 1: path must be one recording path.*an? int"),
        ("- path: true\n", "row 1: path must be .*a boolean"),
        ("- {path: a.mcap, category: [city]}\n", "row 1: category must be text, not a list"),
        ("- {path: a.mcap, vehicle: {id: 3}}\n", "row 1: vehicle must be text, not a mapping"),
        ("- {path: a.mcap, sequence: false}\n", "row 1: sequence must be text, not a boolean"),
        ("- {path: a.mcap, start_s: [1]}\n", "row 1: start_s must be a number of seconds"),
        ("- {path: a.mcap, end_s: true}\n", "row 1: end_s must be a number of seconds"),
        ("- a.mcap\n- [b.mcap]\n", r"row 2: a row is a path or a \{path: ...\} mapping"),
        ("- a.mcap\n- null\n", "row 2: a row is a path"),
        ("- {path: a.mcap, 3: x}\n", "unknown columns"),
    ],
)
def test_manifest_field_types(tmp_path: Path, yaml: str, match: str) -> None:
    (tmp_path / "m.yaml").write_text(yaml)
    with pytest.raises(ConfigError, match=match):
        read_manifest(tmp_path / "m.yaml")


def test_manifest_scalar_labels_become_text(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text(
        "- {path: a.mcap, vehicle: 7, date: 2024-05-01, sequence: 2, start_s: 1, end_s: 2.5}\n"
    )
    (entry,) = read_manifest(tmp_path / "m.yaml")
    assert entry == BatchEntry(tmp_path / "a.mcap", "", "7", "2024-05-01", "2", 1.0, 2.5)


def test_manifest_parquet_list_column_is_refused(tmp_path: Path) -> None:
    pd.DataFrame({"path": [["a.mcap"]]}).to_parquet(tmp_path / "m.parquet")
    with pytest.raises(ConfigError, match="row 1: path must be one recording path"):
        read_manifest(tmp_path / "m.parquet")


def test_manifest_bad_format(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text("just: [a, mapping]\n")
    with pytest.raises(ConfigError, match="YAML manifest"):
        read_manifest(tmp_path / "m.yaml")
    (tmp_path / "m.xlsx").write_text("x")
    with pytest.raises(ConfigError, match=r"\.csv"):
        read_manifest(tmp_path / "m.xlsx")


def test_recording_id_is_content_based(tmp_path: Path) -> None:
    sha = "ab" * 32
    a = recording_id(BatchEntry(Path("/x/Drive 1 (front).mcap")), sha)
    b = recording_id(BatchEntry(Path("/elsewhere/Drive 1 (front).mcap")), sha)
    assert a == b == "Drive_1_front-" + sha[:10]
    seq1 = recording_id(BatchEntry(Path("/x/d.mcap"), sequence="s1", start_s=0, end_s=5), sha)
    seq2 = recording_id(BatchEntry(Path("/x/d.mcap"), sequence="s2", start_s=5, end_s=9), sha)
    assert seq1.startswith("d-s1-")
    assert seq2.startswith("d-s2-")
    assert seq1 != seq2


def test_job_units_split_or_grouped() -> None:
    p = Path("/r/d.mcap")
    entries = [
        BatchEntry(p, "highway", "car", "2024", "s1", 0.0, 10.0),
        BatchEntry(p, "city", "car", "2024", "s2", 10.0, None),
        BatchEntry(Path("/r/e.mcap"), "rain"),
    ]
    split = job_units(entries, split_sequences=True)
    assert [w for _, w in split] == [{"start_s": 0.0, "end_s": 10.0}, {"start_s": 10.0}, {}]
    grouped = job_units(entries, split_sequences=False)
    assert len(grouped) == 2
    entry, extra = grouped[0]
    assert entry == BatchEntry(p, "highway", "car", "2024")
    assert extra == {
        "category": "highway",
        "segments": [
            {"start_s": 0.0, "stop_s": 10.0, "category": "highway"},
            {"start_s": 10.0, "stop_s": 1e9, "category": "city"},
        ],
    }
    assert grouped[1][1] == {"category": "rain"}


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        (
            "m.yaml",
            "- path: d.mcap\n  end_s: .nan\n",
            "end_s must be a finite number >= 0 s, not nan",
        ),
        ("m.csv", "path,category\nd.mcap,a,b,c\n", "cannot read manifest: Length of header"),
        ("m.yaml", "- path: 12\n", "path must be one recording path (text), not an int (12)"),
        ("m.csv", "path\n\x00\x01\n", "row 1: path holds a NUL byte"),
    ],
)
def test_manifest_nan_window_and_ragged_csv_row_are_refused(
    tmp_path: Path, name: str, text: str, message: str
) -> None:
    """Fuzz findings: a YAML .nan window was taken as no window; a CSV row with more fields
    than the header shifted its cells (``b`` read as the path)."""
    from superlane_tools.commands.batch.manifest import read_manifest

    (tmp_path / "d.mcap").write_bytes(b"")
    manifest = tmp_path / name
    manifest.write_text(text)
    with pytest.raises(ConfigError, match=re.escape(message)):
        read_manifest(manifest)
