"""``pipelines/nightly.py --history``: each night's fleet summary and comparison are appended."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.fleet.history import read_history

pytestmark = pytest.mark.slow  # two batch runs in worker processes
SCRIPT = Path(__file__).resolve().parents[3] / "pipelines" / "nightly.py"


@pytest.fixture(scope="module")
def nightly() -> ModuleType:
    spec = importlib.util.spec_from_file_location("slt_nightly_history", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _config(path: Path, labels: Path) -> Path:
    path.write_text(
        "segmentation:\n  backend: oracle\n"
        f"  oracle_labels: {labels}\n"
        "output:\n  plots: false\n  example_frames: 0\nkpi:\n  window_s: 0.25\n",
        encoding="utf-8",
    )
    return path


def test_nightly_appends_each_night_to_the_history(
    oracle_runs: Any, nightly: ModuleType, tmp_path: Path
) -> None:
    rec = oracle_runs.recording
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(f"path\n{rec}\n", encoding="utf-8")
    good = _config(tmp_path / "good.yaml", rec.parent / "curves_labels" / "labels")
    blind = _config(tmp_path / "blind.yaml", oracle_runs.blind.parent.parent / "blind_labels")
    common = ["--manifest", str(manifest), "--workers", "1", "--job", "reprocess"]
    history = tmp_path / "nightly"
    production = tmp_path / "production"
    first = [*common, "--out", str(production), "--config", str(good)]
    assert nightly.main([*first, "--history", str(history), "--night", "2026-11-01"]) == 0
    tonight = [*common, "--out", str(tmp_path / "tonight"), "--config", str(blind)]
    args = [*tonight, "--baseline", str(production), "--history", str(history), "--mine", "2"]
    assert nightly.main([*args, "--night", "2026-11-02"]) == 0  # no gate asked for
    table = read_history(history)
    kinds = table.groupby("night")["kind"].unique().map(sorted).to_dict()
    assert kinds == {"2026-11-01": ["fleet"], "2026-11-02": ["compare", "fleet"]}
    super_ = table[table["kpi"] == "availability_frames.super"].set_index(["night", "kind"])
    # the oracle drive's frame 7 fits a 7.3 m pair ("too wide"); the blind run loses 24 more
    assert np.isclose(super_.loc[("2026-11-01", "fleet"), "value"], 59 / 60)
    assert np.isclose(super_.loc[("2026-11-02", "fleet"), "value"], 35 / 60)
    compare = super_.loc[("2026-11-02", "compare")]
    assert compare["baseline"] == str(production)
    assert np.isclose(compare["delta"], -0.4)
    assert compare["verdict"] == "too few drives"  # one drive: no fleet verdict
    shown = CliRunner().invoke(app, ["history", str(history), "-o", str(tmp_path / "page")])
    assert shown.exit_code == 0, shown.output
    assert "2 nights, 21 KPIs" in shown.output
    assert (tmp_path / "page" / "history.md").is_file()
    assert nightly.main([*args, "--night", "yesterday"]) == 2
