"""``slt compare`` on real reprocess runs of a simulated drive (see conftest.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.commands.compare import CompareParams, compare_runs
from superlane_tools.fleet import (
    DESCRIPTIVE,
    EQUIVALENT,
    TOO_FEW,
    UNAVAILABLE,
    WORSE,
    FleetError,
    difference_lines,
    parse_rule,
)
from superlane_tools.reporting.layout import CompareLayout, checked_table, tables_of

runner = CliRunner()
QUICK = CompareParams(plots=False)


def _check_tables(out: Path) -> None:
    """Every table written matches its declared schema (compare_spans is what mine reads)."""
    for name, spec in tables_of("compare").items():
        checked_table(spec, pq.read_table(CompareLayout(out).table(name)))


def test_one_drive_is_too_few_for_a_verdict(oracle_runs: Any, tmp_path: Path) -> None:
    result = compare_runs(oracle_runs.base, oracle_runs.repeat, tmp_path, QUICK)
    fleet = result.comparison.fleet_rows()
    assert len(result.comparison.matched) == 1
    assert result.comparison.paired
    timing = fleet["kpi"] == "frames_per_s"  # measured CPU time: never reproducible exactly
    available = fleet[~timing & (fleet["verdict"] != UNAVAILABLE)]
    assert len(available) >= 12, fleet[["kpi", "verdict"]]
    assert (available["verdict"] == TOO_FEW).all(), available[["kpi", "verdict"]]
    assert (available["delta"] == 0).all()
    assert (available["n_drives"] == 1).all()
    assert result.differences.empty
    assert result.spans.empty
    table = pd.read_parquet(tmp_path / "compare.parquet")
    assert set(table["scope"]) == {"fleet", "drive", "sequence"}
    assert (table.loc[table["scope"] == "drive", "verdict"] == DESCRIPTIVE).all()
    text = (tmp_path / "compare.md").read_text()
    assert text.index("What differs") < text.index("Fleet verdict")
    assert "matched: 1 of 1 base and 1 candidate drives" in text
    assert "too few drives (1)" in text
    _check_tables(tmp_path)


def test_identical_fleets_are_equivalent_without_a_fake_interval(
    copy_fleets: Any, tmp_path: Path
) -> None:
    result = compare_runs(copy_fleets.base, copy_fleets.repeat, tmp_path, QUICK)
    fleet = result.comparison.fleet_rows()
    assert result.comparison.n_drives() == (10, 10, 10)
    judged = fleet[(fleet["kpi"] != "frames_per_s") & (fleet["verdict"] != UNAVAILABLE)]
    assert len(judged) >= 12
    assert (judged["verdict"] == EQUIVALENT).all(), judged[["kpi", "verdict"]]
    assert (judged["note"].str.startswith("zero spread")).all()
    text = (tmp_path / "compare.md").read_text()
    assert "none: the same change on every drive" in text
    assert "[+0, +0]" not in text
    assert result.gate.code == 0


def test_a_blind_candidate_is_worse_and_its_span_is_found(
    oracle_runs: Any, copy_fleets: Any, tmp_path: Path
) -> None:
    params = CompareParams(gate=(parse_rule("availability_frames.super:1"),))
    result = compare_runs(copy_fleets.base, copy_fleets.blind, tmp_path, params)
    fleet = result.comparison.fleet_rows().set_index("kpi")
    assert fleet.at["availability_frames.super", "verdict"] == WORSE
    assert fleet.at["ego_pair_share", "verdict"] == WORSE
    assert fleet.at["availability_frames.corridor_net", "verdict"] == EQUIVALENT  # not oracle
    assert fleet.at["availability_frames.super", "n_drives"] == 10
    assert result.gate.code == 4
    assert result.regressions[0].startswith("availability_frames.super")
    top = result.spans.iloc[0]
    assert top["first_frame"] <= oracle_runs.blind_frames.start + 3
    assert top["last_frame"] >= oracle_runs.blind_frames.stop - 4
    assert Path(top["base_annotations"]).is_file()
    assert Path(top["candidate_annotations"]).is_file()
    lines = difference_lines(result.differences)
    assert len(lines) == 1, lines  # one real difference, nothing identical listed
    assert lines[0].startswith("segmentation.oracle_labels: base ")
    assert (tmp_path / "plots" / "deltas.png").is_file()
    assert (tmp_path / "plots" / "timeline_0.png").is_file()
    text = (tmp_path / "compare.md").read_text()
    assert "release gate: FAILED" in text
    assert "Holm" in text
    assert (tmp_path / "compare.html").is_file()
    _check_tables(tmp_path)


def _cli(*args: str) -> Any:
    return runner.invoke(app, ["compare", *args, "--no-plots"])


def test_cli_exit_codes(oracle_runs: Any, copy_fleets: Any, tmp_path: Path) -> None:
    gate = ("--fail-on-regression", "availability_frames.super")
    ok = _cli(str(copy_fleets.base), str(copy_fleets.repeat), "-o", str(tmp_path / "a"), *gate)
    assert ok.exit_code == 0, ok.output
    gated = _cli(
        str(copy_fleets.base), str(copy_fleets.blind), "-o", str(tmp_path / "b"),
        "--fail-on-regression", "availability_frames",
    )  # fmt: skip
    assert gated.exit_code == 4, gated.output
    assert "slt: regression: availability_frames.super" in gated.output
    bad = runner.invoke(app, ["compare", "a", "b", "--fail-on-regression", "nope"])
    assert bad.exit_code == 2
    not_run = runner.invoke(app, ["compare", "a", str(tmp_path), "-o", str(tmp_path / "c")])
    assert not_run.exit_code == 1
    assert "Traceback" not in not_run.output


@pytest.mark.parametrize(
    ("candidate", "gate", "code", "line"),
    [
        ("lost", "curvature_rmse_dynamics.super_path", 4, "by the candidate on no drive"),
        ("shifted", "availability_frames.super", 3, "no matched sequences"),
        ("other", "availability_frames.super", 3, "no matched drive (10 base, 10 candidate"),
        ("small", "availability_frames.super", 3, "too few drives"),
    ],
)
def test_the_gate_never_passes_what_it_could_not_judge(
    copy_fleets: Any, tmp_path: Path, candidate: str, gate: str, code: int, line: str
) -> None:
    result = _cli(
        str(copy_fleets.base), str(getattr(copy_fleets, candidate)), "-o", str(tmp_path / "out"),
        "--fail-on-regression", gate,
    )  # fmt: skip
    assert result.exit_code == code, result.output
    assert line in result.output
    assert "Traceback" not in result.output


def test_unmatched_drives_are_listed(oracle_runs: Any, tmp_path: Path) -> None:
    result = runner.invoke(
        app,
        [
            "compare",
            str(oracle_runs.base.parent),
            str(oracle_runs.repeat.parent),
            "-o",
            str(tmp_path),
            "--no-plots",
        ],
    )
    assert result.exit_code == 3, result.output
    assert "slt: skipped: drive only in the base" in result.output
    drives = pd.read_parquet(tmp_path / "compare_drives.parquet")
    assert (drives["status"] == "matched").sum() == 1
    assert drives.loc[drives["status"] != "matched", "drive"].tolist() == ["short"]
    assert (
        "only in the base (1, left out of the deltas): short"
        in (tmp_path / "compare.md").read_text()
    )


def test_an_empty_folder_is_not_a_fleet(tmp_path: Path) -> None:
    with pytest.raises(FleetError, match="not a reprocess run folder"):
        compare_runs(tmp_path, tmp_path, tmp_path / "out", QUICK)


def _older_run(src: Path, dst: Path, version: str, drop: str | None) -> Path:
    """Copy a run as if an older tool version wrote it (its provenance says so)."""
    import json
    import shutil

    import pyarrow.parquet as pq

    from superlane_tools.reporting.parquet import METADATA_KEY
    from superlane_tools.reporting.run_folder import write_run_manifest

    shutil.copytree(src, dst)
    path = dst / "availability_sequences.parquet"
    table = pq.read_table(path)
    meta = json.loads(table.schema.metadata[METADATA_KEY])
    meta["tool_version"] = version
    if drop:
        table = table.drop_columns([drop])
    table = table.replace_schema_metadata({METADATA_KEY: json.dumps(meta).encode()})
    pq.write_table(table, path)
    (dst / "run_manifest.json").unlink()
    write_run_manifest(dst)
    return dst


def test_other_tool_versions_are_named(oracle_runs: Any, tmp_path: Path) -> None:
    same_tables = _older_run(oracle_runs.repeat, tmp_path / "v0_9", "0.9.0", None)
    result = compare_runs(oracle_runs.base, same_tables, tmp_path / "a", QUICK)
    first = result.differences.iloc[0]
    assert (first["what"], first["candidate"]) == ("tool version", "0.9.0")
    text = (tmp_path / "a" / "compare.md").read_text()
    assert "- tool version: base " in text
    assert "the tool versions differ" in text
    old = _older_run(oracle_runs.repeat, tmp_path / "v0_1", "0.1.0-old", "start_ns")
    cli = runner.invoke(
        app, ["compare", str(oracle_runs.base), str(old), "-o", str(tmp_path / "b")]
    )
    assert cli.exit_code == 1
    assert "tool version 0.1.0-old lacks start_ns: incompatible" in cli.output


def test_a_batch_root_without_finished_drives_is_an_empty_fleet(
    oracle_runs: Any, tmp_path: Path
) -> None:
    from superlane_tools.commands.batch.status import COLUMNS
    from superlane_tools.reporting import Provenance, write_table

    row: dict[str, object] = dict.fromkeys(COLUMNS, "")
    row.update(
        recording_id="curves-0123456789",
        status="failed",
        result="failed",
        error="corrupt recording",
        attempts=1,
        size_bytes=0,
        mtime_ns=0,
        total_s=0.0,
        outputs=0,
        frames=0,
        finished_ns=0,
        start_s=float("nan"),
        end_s=float("nan"),
    )
    write_table(
        pd.DataFrame([row]).astype(COLUMNS),
        tmp_path / "root" / "batch_status.parquet",
        Provenance(command="test"),
    )
    cli = runner.invoke(
        app, ["compare", str(oracle_runs.base), str(tmp_path / "root"), "-o", str(tmp_path / "out")]
    )
    assert cli.exit_code == 1
    assert "empty fleet" in cli.output
