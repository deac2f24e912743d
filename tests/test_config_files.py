"""The one mapping-file loader: TOML, YAML and JSON by suffix, one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.config_files import load_document, load_mapping
from superlane_tools.errors import ConfigError


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("c.toml", "[kpi]\nwindow_s = 10.0\n"),
        ("c.yaml", "kpi:\n  window_s: 10.0\n"),
        ("c.yml", "kpi: {window_s: 10.0}\n"),
        ("c.json", '{"kpi": {"window_s": 10.0}}'),
    ],
)
def test_every_format_gives_the_same_mapping(tmp_path: Path, name: str, text: str) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    assert load_mapping(path) == {"kpi": {"window_s": 10.0}}


def test_empty_yaml_is_an_empty_mapping_and_a_list_is_a_document(tmp_path: Path) -> None:
    empty = tmp_path / "e.yaml"
    empty.write_text("", encoding="utf-8")
    assert load_mapping(empty) == {}
    items = tmp_path / "segments.txt"
    items.write_text("- {start_s: 0, stop_s: 5}\n", encoding="utf-8")
    assert load_document(items, "manifest", suffix=".yaml") == [{"start_s": 0, "stop_s": 5}]


def test_errors_name_the_file_and_what_it_is(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"cannot read manifest .*missing\.yaml"):
        load_document(tmp_path / "missing.yaml", "manifest")
    bad = tmp_path / "bad.toml"
    bad.write_text("[kpi\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"bad\.toml: not valid TOML"):
        load_mapping(bad)
    listing = tmp_path / "list.json"
    listing.write_text("[1, 2]", encoding="utf-8")
    with pytest.raises(ConfigError, match="the class map must be a mapping"):
        load_mapping(listing, "class map")
