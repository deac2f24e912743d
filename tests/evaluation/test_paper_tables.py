"""`slt tables paper`: evaluation records laid out as the SUPER paper's tables, with sources."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.evaluation import TuSimpleRecord, format_record
from superlane_tools.reporting import read_provenance
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.paper_tables import (
    EvalRecord,
    file_ref,
    load_record,
    paper_cells,
    paper_latex,
    paper_markdown,
    save_record,
)

ROWS = [float(r) for r in range(300, 720, 20)]


def _labels(tmp_path: Path) -> Path:
    lanes = [[300 - 0.5 * (r - 700) for r in ROWS], [900 + 0.5 * (r - 700) for r in ROWS]]
    gt = TuSimpleRecord("a.jpg", lanes, ROWS, 0.0, ("yellow", "white"), ("solid", "dashed"))
    path = tmp_path / "gt.json"
    path.write_text(format_record(gt) + "\n")
    return path


def _pred(tmp_path: Path, shift: float, name: str) -> Path:
    lanes = [[300 - 0.5 * (r - 700) + shift for r in ROWS], [900 + 0.5 * (r - 700) for r in ROWS]]
    rec = TuSimpleRecord("a.jpg", lanes, [], 5.0, ("white", "white"), ("solid", "dashed"))
    path = tmp_path / name
    path.write_text(format_record(rec) + "\n")
    return path


def test_table2_fig9_from_the_cli(tmp_path: Path) -> None:
    gt = _labels(tmp_path)
    runner = CliRunner()
    recs = []
    for row, col, shift in (("no sq", "no sc", 50.0), ("no sq", "sc", 0.0), ("sq", "sc", 0.0)):
        pred = _pred(tmp_path, shift, f"p_{row}_{col}.json".replace(" ", ""))
        rec = tmp_path / f"r{len(recs)}.json"
        res = runner.invoke(
            app,
            [
                "eval",
                "tusimple",
                str(pred),
                str(gt),
                "--row",
                row,
                "--column",
                col,
                "--save",
                str(rec),
            ],
        )
        assert res.exit_code == 0, res.output
        recs.append(rec)
    pred = _pred(tmp_path, 0.0, "p_ego.json")
    for mode in ("ego", "3lane"):
        rec = tmp_path / f"m_{mode}.json"
        args = [
            "eval",
            "tusimple",
            str(pred),
            str(gt),
            "--mode",
            mode,
            "--row",
            "SUPER",
            "--column",
            "easy",
            "--save",
            str(rec),
        ]
        assert runner.invoke(app, args).exit_code == 0
        recs.append(rec)
    rec = tmp_path / "attr.json"
    args = ["eval", "attributes", str(pred), str(gt), "--row", "SUPER", "--save", str(rec)]
    assert runner.invoke(app, args).exit_code == 0
    recs.append(rec)
    md = tmp_path / "paper.md"
    res = runner.invoke(app, ["tables", "paper", *map(str, recs), "--out", str(md)])
    assert res.exit_code == 0, res.output
    text = md.read_text()
    assert "| no sq | 50.00% [1] | 100.00% [2] |" in text
    assert "| sq |  | 100.00% [3] |" in text
    assert "ego: easy" in text
    assert text.index("ego: easy") < text.index("3lane: easy")
    assert "| SUPER | 100.00% [1] | 100.00% [2] | 50.00% [3] | 100.00% [3] |" in text
    assert "--row 'no sq'" in text  # the command is quoted as typed
    tex = tmp_path / "paper.tex"
    assert (
        runner.invoke(app, ["tables", "paper", *map(str, recs), "--out", str(tex)]).exit_code == 0
    )
    assert r"\begin{tabular}" in tex.read_text()
    pq_out = tmp_path / "paper.parquet"
    res = runner.invoke(app, ["tables", "paper", *map(str, recs), "--out", str(pq_out)])
    assert res.exit_code == 0
    cells = pq.read_table(pq_out).to_pandas()
    assert set(cells["table"]) == {"Table 2", "Fig. 9"}
    cell = cells[(cells["table"] == "Table 2") & (cells["column"] == "no sc")].iloc[0]
    assert cell["value"] == pytest.approx(0.5)
    assert cell["predictions"].endswith("p_nosq_nosc.json")
    assert len(cell["predictions_sha256"]) == 64
    assert "tables paper" in read_provenance(pq_out)["command"]
    res = runner.invoke(app, ["tables", "paper", str(recs[1]), str(recs[1])])
    assert res.exit_code != 0
    assert "both fill" in res.output


def test_table3_table4_and_culane_layout(tmp_path: Path) -> None:
    gt = _labels(tmp_path)
    ref = file_ref(gt)
    clips = {
        name: {"tpr": tpr}
        for name, tpr in (
            ("cordova1", 0.9),
            ("cordova2", 0.8),
            ("washington1", 0.7),
            ("washington2", 0.6),
        )
    }
    kitti = {
        "max_f": 0.867,
        "precision": 0.86,
        "recall": 0.874,
        "fpr": 0.022,
        "average_precision": 0.8,
        "fnr": 0.126,
    }
    culane = {"sets": {"all": {"f1_50": 0.75, "f1_75": 0.5, "mf1": 0.45}}}
    records = [
        EvalRecord("caltech", "SUPER", "", {"clips": clips}, "slt eval caltech P D", ref, ref),
        EvalRecord("kitti", "SUPER", "", kitti, "slt eval kitti P D", ref, ref),
        EvalRecord("culane", "SUPER", "", culane, "slt eval culane P D", ref, ref),
    ]
    paths = [save_record(r, tmp_path / f"{r.kind}.json") for r in records]
    loaded = [load_record(p) for p in paths]
    assert loaded[1].metrics["max_f"] == 0.867
    cells = paper_cells(loaded, [str(p) for p in paths])
    md = paper_markdown(cells)
    assert "| SUPER | 0.900 [1] | 0.800 [1] | 0.700 [1] | 0.600 [1] | 0.750 [1] |" in md
    assert "| SUPER | 86.7 [1] | 86.0 [1] | 87.4 [1] | 2.2 [1] | 80.0 [1] | 12.6 [1] |" in md
    assert "CULane" in md
    assert "$^{1}$" in paper_latex(cells)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"kind": "kitti"}))
    with pytest.raises(OutputError, match="not an evaluation record"):
        load_record(bad)
    with pytest.raises(OutputError):
        paper_cells([], [])
