"""CLI tests of ``slt reprocess`` and ``slt tables`` through their own Typer app."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer
import yaml
from pyarrow.parquet import read_table
from typer.testing import CliRunner

from superlane_tools.cli import reprocess, tables
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.reporting import read_provenance
from superlane_tools.reporting.layout import DERIVED_TABLES, RunLayout, checked_table
from superlane_tools.simulation.drive import simulate_drive

SAMPLE = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"


def _app() -> typer.Typer:
    app = typer.Typer()
    reprocess.register(app)
    tables.register(app)
    return app


def run_cli(*args: str) -> tuple[int, str]:
    """Run the commands; return the exit code and the combined output."""
    result = CliRunner().invoke(_app(), list(args))
    return result.exit_code, result.output


@pytest.fixture(scope="module")
def drives(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    root = tmp_path_factory.mktemp("cli")
    paths = []
    for name in ("heavy_rain", "faded_lines"):
        out = root / f"{name}.mcap"
        simulate_drive(name, 3.0, 2, "mcap", 320, 180, False, out)
        paths.append(out)
    return paths


def test_print_config_round_trips() -> None:
    code, out = run_cli("reprocess", "--print-config")
    assert code == 0
    data = yaml.safe_load(out)
    assert data["kpi"]["min_width_m"] == 2.0
    assert data["corridor"]["mean_frames"] == 3
    from superlane_tools.drive.config import config_from_mapping

    assert config_from_mapping(data) == ReprocessConfig()


def test_bad_config_is_usage_error(tmp_path: Path) -> None:
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[kpi]\nmin_width = 3\n", encoding="utf-8")
    run = str(tmp_path / "run")
    code, out = run_cli("reprocess", str(SAMPLE), "--config", str(cfg), "--out", run)
    assert code == 2
    assert "unknown keys in [kpi]: min_width" in out
    code, out = run_cli("reprocess", str(SAMPLE), "--backend", "magic")
    assert code == 2
    assert "Traceback" not in out


def test_not_a_recording_is_error(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    code, out = run_cli("reprocess", str(junk), "--out", str(tmp_path / "o"))
    assert code == 1
    assert "Traceback" not in out


@pytest.mark.slow
def test_reprocess_and_tables(drives: list[Path], tmp_path: Path) -> None:
    cfg = tmp_path / "fast.toml"
    cfg.write_text("[output]\nplots = false\nannotations = false\n", encoding="utf-8")
    runs = []
    for drive in drives:
        out = tmp_path / drive.stem
        code, text = run_cli(
            "reprocess",
            str(drive),
            "--out",
            str(out),
            "--config",
            str(cfg),
            "--category",
            drive.stem,
        )
        assert code == 0, text
        assert "frames/s" in text
        runs.append(str(out))
    md = tmp_path / "availability.md"
    code, text = run_cli("tables", "availability", *runs, "--by", "category", "--out", str(md))
    assert code == 0, text
    table = md.read_text(encoding="utf-8")
    assert "heavy_rain" in table
    assert "faded_lines" in table
    assert "total" in table
    assert "SUPER n/N" in table
    assert "Hough k/K" in table
    tex = tmp_path / "availability.tex"
    assert run_cli("tables", "availability", *runs, "--out", str(tex))[0] == 0
    assert r"\begin{tabular}" in tex.read_text(encoding="utf-8")
    pq = tmp_path / "curvature.parquet"
    code, text = run_cli("tables", "curvature", *runs, "--out", str(pq))
    assert code == 0, text
    assert read_provenance(pq)["inputs"]
    code, text = run_cli("tables", "curvature", *runs)
    assert code == 0
    assert "SUPER raw (2*a2" in text  # the same name as in the report and the plots
    code, text = run_cli("tables", "curvature", str(tmp_path))
    assert code == 1
    assert "not a reprocess run folder" in text


@pytest.mark.slow
def test_sample_drive_with_no_options(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    if not SAMPLE.is_file():
        pytest.skip("fixtures/sample_drive.mcap not generated yet")
    monkeypatch.chdir(tmp_path)
    code, text = run_cli("reprocess", str(SAMPLE))
    assert code == 0, text
    assert "reprocessed 240 frames" in text
    last = text.rstrip().splitlines()[-1]  # report.html and one number per method
    assert last.startswith("report: runs/sample_drive/report.html -- SUPER "), last
    assert last.endswith(" of frames available"), last
    run = tmp_path / "runs" / "sample_drive"
    for name in ("report.md", "report.html", "annotations.mcap", "plots/curvature_time.png"):
        assert (run / name).is_file(), name
    for name in DERIVED_TABLES:  # every derived table as its schema declares it
        table = read_table(RunLayout(run).table(name))
        assert checked_table(name, table).num_rows > 0, name
    frames = pd.read_parquet(run / "frames.parquet")
    assert len(frames) == 240
    assert frames["ok"].all()
    # The quick start's numbers, against the simulator's ground truth (fixture: 16 s highway).
    gt = pd.read_parquet(SAMPLE.with_name("sample_drive.gt.parquet"))
    lanes = pd.read_parquet(run / "lanes.parquet")
    assert lanes["lane_width"].notna().mean() > 0.95
    assert np.nanmedian(np.abs(lanes["b"] - gt["road_slope"])) < 0.005
    summary = pd.read_parquet(run / "curvature_summary.parquet")
    path = summary[(summary["scope"] == "overall") & (summary["source"] == "super_path")].iloc[0]
    assert path["rmse"] < 1e-3  # measured 5.0e-4 1/m
    assert path["correlation"] > 0.95  # measured 0.993
    seqs = pd.read_parquet(run / "availability_sequences.parquet").set_index("method")
    assert seqs.loc["super", "ratio"] > 0.95  # measured 1.0
    assert seqs.loc["hough", "ratio"] < seqs.loc["super", "ratio"]
