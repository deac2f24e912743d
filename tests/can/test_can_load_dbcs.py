"""``load_dbcs``: the shipped DBCs by default, ``BUS=FILE`` names, and bad specs."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.can import CanError, load_dbcs, shipped_dbcs


def test_no_spec_loads_the_shipped_dbcs_or_none() -> None:
    loaded, files = load_dbcs([])
    assert files == shipped_dbcs()
    assert list(loaded) == [p.name for p in shipped_dbcs()]
    assert all(d.database.messages for d in loaded.values())
    assert load_dbcs([], shipped=False) == ({}, [])


def test_bus_bound_specs_are_named_bus_equals_file() -> None:
    first, second = shipped_dbcs()[:2]
    loaded, files = load_dbcs([str(first), f"can1={second}"])
    assert list(loaded) == [first.name, f"can1={second.name}"]
    assert files == [first, second]


def test_a_missing_dbc_is_a_can_error(tmp_path: Path) -> None:
    with pytest.raises(CanError):
        load_dbcs([str(tmp_path / "absent.dbc")])
    with pytest.raises(CanError, match="BUS=FILE"):
        load_dbcs(["can0="])
