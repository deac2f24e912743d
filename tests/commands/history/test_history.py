"""``slt history`` on a history built from real reprocess runs and real ``slt compare`` runs.

Five nights of the 4 s oracle drive of tests/commands/conftest.py: night k's run is blind
(blank oracle labels) in frames 20 .. 20 + 3k - 1, so SUPER's availability falls 3 frames (5 pp) a
night from 59 of 60 frames; each night is compared with the night before and gated on
``availability_frames.super:2``. Night 3 changes the corridor threshold (a configuration
change), night 4 the corridor network (``ego_corridor_v2``: a model change).
"""

from __future__ import annotations

import hashlib
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.commands.compare import CompareParams, compare_runs
from superlane_tools.commands.history import HistoryParams, history_report
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.fleet import parse_rule
from superlane_tools.fleet.history import read_history, record_night
from superlane_tools.reporting.layout import HISTORY_DRIFTS_TABLE, checked_table
from superlane_tools.reporting.run_folder import staged_run

runner = CliRunner()
NIGHTS = [f"2026-11-{k:02d}" for k in range(1, 6)]
KPI = "availability_frames.super"

FIRST = 59 / 60
"""Night 0's SUPER availability: the oracle's frame 7 fits a 7.3 m pair (a dash gap under the
20-point line evidence rule) and is "too wide"; the blinding takes 3 frames more each night."""


@dataclass(frozen=True)
class History:
    """The history root, each night's fleet root and the gate's regressions per night."""

    root: Path
    fleets: list[Path]
    regressions: list[tuple[str, ...]]


def _night_config(
    base: ReprocessConfig, k: int, labels: Path, blind: Path, oracle: Callable[..., Any]
) -> ReprocessConfig:
    import cv2

    folder = blind  # one folder, refilled every night: the configuration names the same path
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(labels, folder)
    for frame in range(20, 20 + 3 * k):
        path = folder / f"{frame:06d}.png"
        cv2.imwrite(str(path), np.zeros_like(cv2.imread(str(path), cv2.IMREAD_UNCHANGED)))
    overrides: dict[str, object] = {}
    if k >= 2:
        overrides["corridor.threshold"] = 0.45
    if k >= 3:
        overrides["corridor.model"] = "ego_corridor_v2"
    config: ReprocessConfig = oracle(folder)
    return config.with_overrides(overrides) if overrides else config


def _files(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*.parquet"))
    }


@pytest.fixture(scope="module")
def history(
    tmp_path_factory: pytest.TempPathFactory,
    oracle_runs: Any,
    oracle_config: Callable[[Path], ReprocessConfig],
) -> History:
    """Five nights reprocessed, compared night over night, appended to one history."""
    root = tmp_path_factory.mktemp("history")
    labels = oracle_runs.recording.parent / "curves_labels" / "labels"
    fleets, regressions = [], []
    gate = CompareParams(plots=False, gate=(parse_rule(f"{KPI}:2"),))
    for k, night in enumerate(NIGHTS):
        fleet = root / "fleets" / night
        config = _night_config(oracle_config(labels), k, labels, root / "labels", oracle_config)
        with staged_run(fleet / "curves") as stage:
            reprocess(oracle_runs.recording, stage, config, command=f"test night {k}")
        compare_dir = baseline = None
        if fleets:
            baseline, compare_dir = fleets[-1], root / "compare" / night
            result = compare_runs(baseline, fleet, compare_dir, gate)
            regressions.append(result.regressions)
        before = _files(root / "nightly")
        written = record_night(root / "nightly", night, fleet, compare_dir, baseline)
        after = _files(root / "nightly")
        # appended, never rewritten: the old files are byte for byte the same, one or two new
        assert {p: h for p, h in after.items() if p in before} == before
        assert len(after) == len(before) + (2 if compare_dir else 1) == len(before) + len(written)
        fleets.append(fleet)
    return History(root / "nightly", fleets, regressions)


def test_the_history_holds_every_night_fleet_and_comparison(history: History) -> None:
    table = read_history(history.root)
    assert sorted(table["night"].unique()) == NIGHTS
    per_night = table.groupby(["night", "kind"]).size().unstack(fill_value=0)
    assert (per_night["fleet"] == 21).all()
    assert list(per_night["compare"]) == [0, 21, 21, 21, 21]
    fleet = table[(table["kind"] == "fleet") & (table["kpi"] == KPI)].set_index("night")
    assert np.allclose(fleet["value"], [FIRST - 3 * k / 60 for k in range(5)])
    assert (fleet["n_drives"] == 1).all()
    assert (fleet["n_sequences"] == 15).all()
    comp = table[(table["kind"] == "compare") & (table["kpi"] == KPI)].set_index("night")
    assert np.allclose(comp["delta"], -0.05)
    assert (comp["verdict"] == "too few drives").all()  # the drive is the unit: one drive
    assert comp["ci_low"].isna().all()  # gives no interval
    assert set(comp["baseline"]) == {str(f) for f in history.fleets[:-1]}
    # with pandas, as docs/compare.md shows: the night comes back from the partitions
    plain = pd.read_parquet(history.root / "history")
    assert len(plain) == len(table)
    assert set(plain["night"].astype(str)) == set(NIGHTS)


def test_a_drift_every_night_s_gate_passed_is_flagged(history: History, tmp_path: Path) -> None:
    assert history.regressions == [(), (), (), ()]  # no night's gate failed
    result = history_report(history.root, tmp_path, HistoryParams(plots=False))
    verdicts = result.series[result.series["kpi"] == KPI]["verdict"].dropna()
    assert "worse" not in set(verdicts)
    alarms = result.uncaught[result.uncaught["kpi"] == KPI]
    assert len(alarms) == 1  # one drift: both rules' alarms over these nights joined
    decline = alarms.iloc[0]
    assert decline["rule"] == "decline+cusum"
    assert (decline["first_night"], decline["last_night"]) == (NIGHTS[0], NIGHTS[-1])
    assert np.isclose(decline["change"], -0.2)
    assert any(line.startswith(f"{KPI}: 98.3% -> 78.3% (-20.0 pp)") for line in result.drift_lines)
    assert not result.uncaught["kpi"].str.contains("corridor_net").any()


def test_model_and_config_changes_are_marked(history: History, tmp_path: Path) -> None:
    result = history_report(history.root, tmp_path, HistoryParams())
    assert [c[0] for c in result.model_changes] == [NIGHTS[3]]
    assert "ego_corridor_v2" in result.model_changes[0][2]
    assert "ego_corridor_v3" in result.model_changes[0][1]
    assert [c[0] for c in result.config_changes] == [NIGHTS[2], NIGHTS[3]]
    page = (tmp_path / "history.md").read_text(encoding="utf-8")
    assert "## Model and configuration changes" in page
    assert page.index("## Drifts no gate caught") < page.index("## Model and configuration")
    assert (tmp_path / "plots" / "history_availability_frames_super.png").stat().st_size > 5000
    assert (tmp_path / "history.html").is_file()
    drifts = pd.read_parquet(tmp_path / "history_drifts.parquet")
    assert len(drifts) == len(result.drifts) > 0
    checked_table(HISTORY_DRIFTS_TABLE, drifts)  # the declared schema


def test_a_rerun_night_appends_a_file_and_the_latest_wins(history: History, tmp_path: Path) -> None:
    copy = tmp_path / "nightly"
    shutil.copytree(history.root, copy)
    before = _files(copy)
    record_night(copy, NIGHTS[-1], history.fleets[-1])
    after = _files(copy)
    assert len(after) == len(before) + 1
    assert {p: h for p, h in after.items() if p in before} == before
    assert len(read_history(copy)) == len(read_history(history.root))
    assert len(read_history(copy, latest=False)) == len(read_history(history.root)) + 21


def test_cli(history: History, tmp_path: Path) -> None:
    base = ["history", str(history.root), "-o", str(tmp_path / "page"), "--no-plots"]
    ok = runner.invoke(app, base)
    assert ok.exit_code == 0, ok.output
    assert "5 nights, 21 KPIs, 1 model changes" in ok.output
    assert f"slt: drift: {KPI}: 98.3% -> 78.3%" in ok.output
    kept = runner.invoke(app, [*base, "--fail-on-drift"])
    assert kept.exit_code == 2  # the page exists: --overwrite replaces it
    gated = runner.invoke(app, [*base, "--fail-on-drift", "--overwrite"])
    assert gated.exit_code == 4
    wide = runner.invoke(app, [*base, "--margin", f"{KPI}:0.5", "--overwrite"])
    assert wide.exit_code == 0
    assert f"slt: drift: {KPI}" not in wide.output  # a 50 pp margin: 20 pp is no drift


def test_bad_input_is_one_line_and_exit_2(history: History, tmp_path: Path) -> None:
    empty = runner.invoke(app, ["history", str(tmp_path)])
    assert empty.exit_code == 2
    lines = empty.output.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("slt: error: ")
    assert "not a history root" in lines[0]
    inside = runner.invoke(app, ["history", str(history.root), "-o", str(history.root / "history")])
    assert inside.exit_code == 2
    kpi = runner.invoke(app, ["history", str(history.root), "--kpi", "nope", "-o", str(tmp_path)])
    assert kpi.exit_code == 2
    assert "KPI not in the history: nope" in kpi.output
    margin = runner.invoke(app, ["history", str(history.root), "--margin", "x"])
    assert margin.exit_code == 2


def test_duckdb_reads_the_dataset(history: History) -> None:
    duckdb = pytest.importorskip("duckdb")  # the optional extra 'history'
    glob = history.root / "history" / "*" / "*.parquet"
    rows = duckdb.sql(
        f"SELECT night, value FROM read_parquet('{glob}', hive_partitioning = true) "
        f"WHERE kpi = '{KPI}' AND kind = 'fleet' ORDER BY night"
    ).df()
    assert list(rows["night"].astype(str)) == NIGHTS


def test_n_drives_is_read_when_the_comparison_has_it(history: History, tmp_path: Path) -> None:
    from superlane_tools.reporting import Provenance, write_table

    night = NIGHTS[1]
    table = pd.read_parquet(history.root.parent / "compare" / night / "compare.parquet")
    for name, n_drives in (("without", None), ("with", 1)):
        folder = tmp_path / name
        written = table.drop(columns=["n_drives"], errors="ignore")
        if n_drives is not None:
            written = written.assign(n_drives=n_drives)
        write_table(written, folder / "compare.parquet", Provenance(command="test"))
        record_night(tmp_path / name, night, history.fleets[1], folder, history.fleets[0])
        rows = read_history(tmp_path / name)
        got = rows.loc[rows["kind"] == "compare", "n_drives"]
        assert got.isna().all() if n_drives is None else (got == n_drives).all(), got
