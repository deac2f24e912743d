"""End-to-end tests of ``reprocess`` on short simulated drives (real MCAP files, no mocks)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.recording import open_recording
from superlane_tools.reporting import read_provenance
from superlane_tools.reporting.layout import (
    CURVATURE_SCHEMA,
    DERIVED_TABLES,
    RunLayout,
    SchemaMismatchError,
    checked_table,
)
from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL
from superlane_tools.simulation.drive import simulate_drive

PARQUETS = (
    "frames",
    "lanes",
    "corridor",
    "baseline",
    "availability_frames",
    "availability_sequences",
    "curvature",
    "curvature_summary",
    "mobileye",
    "rtk",
    "can_signals",
)
FAST = ReprocessConfig().with_overrides({"output.example_frames": 1})


@pytest.fixture(scope="session")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 4 s highway_curves drive at 320x180 with label images."""
    out = tmp_path_factory.mktemp("drive") / "curves.mcap"
    simulate_drive("highway_curves", 4.0, 3, "mcap", 320, 180, True, out)
    return out


@pytest.fixture(scope="session")
def run_dir(drive: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("run") / "curves"
    result = reprocess(drive, out, FAST.with_overrides({"output.video": True}))
    assert result.status == "ok"
    assert result.frames == 60
    return out


def _copy_mcap(src: Path, dst: Path, drop: set[str] = frozenset(), chunk: int = 1 << 20) -> Path:
    """Copy an MCAP's raw messages (no metadata records), leaving out some topics."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with src.open("rb") as fin, dst.open("wb") as fout:
        writer = Writer(fout, chunk_size=chunk)
        writer.start()
        channels: dict[int, int] = {}
        schemas: dict[int, int] = {}
        for schema, channel, message in make_reader(fin).iter_messages(log_time_order=True):
            if channel.topic in drop:
                continue
            if channel.id not in channels:
                if schema is not None and schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
                channels[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schemas.get(schema.id, 0) if schema is not None else 0,
                    dict(channel.metadata),
                )
            writer.add_message(
                channels[channel.id], message.log_time, message.data, message.publish_time
            )
        writer.finish()
    return dst


def test_every_output_exists_with_provenance(run_dir: Path) -> None:
    for name in PARQUETS:
        prov = read_provenance(run_dir / f"{name}.parquet")
        assert prov["tool"] == "superlane-tools"
        assert prov["inputs"][0]["name"] == "curves.mcap"
        assert prov["config"]["resolved"]["segmentation_backend"] in (
            "classical",
            f"onnx:{DEFAULT_SEGMENTATION_MODEL}",
        )
    for name in ("report.md", "report.html", "annotations.mcap", "overlay.mp4"):
        assert (run_dir / name).stat().st_size > 0
    plots = {p.name for p in (run_dir / "plots").glob("*.png")}
    assert {"curvature_time.png", "availability_timeline.png"} <= plots
    assert any(p.startswith("example_") for p in plots)
    lanes = pd.read_parquet(run_dir / "lanes.parquet")
    assert lanes.shape[0] == 60
    fitted = lanes["reason"].isin(["", "one line"])
    assert fitted.any()
    assert (lanes.loc[fitted, "c"] == 0.0).all()  # vertical curvature off by default
    # The report's run section states what this run resolved, line for line.
    resolved = read_provenance(run_dir / "frames.parquet")["config"]["resolved"]
    report = (run_dir / "report.md").read_text(encoding="utf-8").splitlines()
    assert "- camera frames: 60" in report
    assert f"- segmentation backend: {resolved['segmentation_backend']}" in report
    assert f"- corridor network: {resolved['corridor_unavailable'] or 'ran'}" in report
    corridor = pd.read_parquet(run_dir / "corridor.parquet")
    assert set(corridor["status"]) == {resolved["corridor_unavailable"]}
    if not resolved["corridor_unavailable"]:  # its headline row: availability only
        row = next(line for line in report if line.startswith("| Corridor net |"))
        assert row.startswith("| Corridor net | - | - | ")  # no curvature, no floor column
        assert row.split("|")[4].strip().endswith("%")  # its frames available


def test_annotations_are_foxglove_messages(run_dir: Path) -> None:
    with open_recording(run_dir / "annotations.mcap") as rec:
        types = {t.topic: t.msgtype for t in rec.topics()}
        assert types["/slt/annotations"] == "foxglove.ImageAnnotations"
        assert types["/slt/lane_parameters"] == "slt.LaneParameters"  # JSON with a JSON schema
        n = sum(1 for _ in rec.raw_messages(topics=["/slt/annotations"]))
        params = [m.data for m in rec.messages(topics=["/slt/lane_parameters"])]
    assert n == 60
    assert len(params) == 60
    assert any(isinstance(p.curvature_per_m, float) for p in params)
    assert all(isinstance(p.quality, float) for p in params)


def test_curvature_sign_and_scale_match_ground_truth(run_dir: Path, drive: Path) -> None:
    curv = pd.read_parquet(run_dir / "curvature.parquet")
    gt = pd.read_parquet(drive.with_name("curves.gt.parquet"))
    truth = gt["path_curvature"].to_numpy()
    rtk = curv["rtk_curvature"].to_numpy()
    ok = np.isfinite(rtk)
    assert ok.sum() > 20
    # RTK ground truth follows the simulated path curvature (same sign, 1/m)
    assert np.sqrt(np.mean((rtk[ok] - truth[ok]) ** 2)) < 5e-4
    me = curv["mobileye_curvature"].to_numpy()
    both = ok & np.isfinite(me)
    assert np.corrcoef(me[both], rtk[both])[0, 1] > 0.8 or np.ptp(truth) < 1e-3
    assert np.sign(np.nanmean(me[both])) == np.sign(np.nanmean(rtk[both]))
    sup = curv["super_curvature"].to_numpy()
    fine = ok & np.isfinite(sup)
    assert fine.sum() > 20
    assert np.sign(np.median(sup[fine])) == np.sign(np.median(rtk[fine]))
    assert np.median(np.abs(sup[fine] - rtk[fine])) < 3e-3


def test_availability_tables(run_dir: Path) -> None:
    frames = pd.read_parquet(run_dir / "availability_frames.parquet")
    assert set(frames["method"]) == {"super", "corridor_net", "hough", "mobileye"}
    net = frames[frames["method"] == "corridor_net"]
    if (net["reason"].str.startswith("method unavailable")).all():
        assert (~net["available"]).all()
    sup = frames[frames["method"] == "super"]
    assert 2.5 < sup["width_m"].median() < 4.5
    assert (sup.loc[~sup["available"], "reason"] != "").all()
    assert set(sup["reason"]) <= {
        "",
        "too short",
        "too narrow",
        "too wide",
        "no corridor",
        "frame not decoded",
        "not plausible",
    }
    me = frames[frames["method"] == "mobileye"]
    assert me["available"].mean() > 0.5  # the simulated Mobileye sees both lines, quality 3
    assert 2.5 < me["width_m"].median() < 4.5
    seqs = pd.read_parquet(run_dir / "availability_sequences.parquet")
    assert len(seqs) == 4
    assert (seqs["n_frames"] == 60).all()
    report = (run_dir / "report.md").read_text()
    assert report.index("## Headline") < report.index("## Run")
    headline = report.split("## Headline")[1].split("\n## ")[0]
    assert "The truth's own noise floor is" in headline  # once, not a column on every row
    assert "truth noise floor (1/m)" not in headline
    html = (run_dir / "report.html").read_text()
    assert "<code>" in html
    assert "`" not in html


def test_oracle_backend_curvature(drive: Path, tmp_path: Path) -> None:
    labels = drive.parent / "curves_labels" / "labels"
    cfg = FAST.with_overrides(
        {
            "segmentation.backend": "oracle",
            "segmentation.oracle_labels": str(labels),
            "output.plots": False,
            "output.annotations": False,
        }
    )
    result = reprocess(drive, tmp_path / "oracle", cfg)
    assert any("ORACLE" in n for n in result.notes)
    summ = pd.read_parquet(tmp_path / "oracle" / "curvature_summary.parquet")
    sup = summ[(summ["scope"] == "overall") & (summ["source"] == "super")].iloc[0]
    assert sup["n"] > 20
    assert sup["rmse"] < 2.5e-3
    assert set(summ["source"]) == {
        "super",
        "super_road",
        "super_path",
        "super_road_sg",
        "super_path_sg",
        "mobileye",
        "mobileye_path",
        "dynamics",
    }
    curv = pd.read_parquet(tmp_path / "oracle" / "curvature.parquet")
    path = curv["super_path_curvature"].to_numpy()
    ok = np.isfinite(path) & curv["rtk_valid"].to_numpy()
    assert ok.sum() > 5
    # Like-for-like with RTK: the aligned estimate is no worse than the raw 2*a2.
    rtk = curv["rtk_curvature"].to_numpy()
    raw = curv["super_curvature"].to_numpy()
    assert np.sqrt(np.mean((path[ok] - rtk[ok]) ** 2)) < np.sqrt(np.mean((raw[ok] - rtk[ok]) ** 2))


def test_lane_tracker_outputs_and_accuracy(run_dir: Path) -> None:
    curv = pd.read_parquet(run_dir / "curvature.parquet")
    used = curv["super_track_used"].to_numpy()
    assert used.sum() > 0.5 * len(curv)
    assert np.isfinite(curv["super_track_road_curvature"]).sum() > 0.9 * len(curv)
    # The per-frame raw value stays; the tracked path estimate is closer to RTK than it.
    rtk = curv["rtk_curvature"].to_numpy()
    path = curv["super_path_curvature"].to_numpy()
    ok = np.isfinite(path) & np.isfinite(rtk)
    assert ok.sum() > 5
    raw = curv["super_curvature"].to_numpy()
    track_rmse = np.sqrt(np.mean((path[ok] - rtk[ok]) ** 2))
    assert track_rmse < np.sqrt(np.mean((raw[ok] - rtk[ok]) ** 2))
    assert track_rmse < 8e-4
    assert any("lane tracker" in line for line in (run_dir / "report.md").read_text().splitlines())


def test_without_can_and_rtk_degrades_with_statements(drive: Path, tmp_path: Path) -> None:
    rec = _copy_mcap(drive, tmp_path / "nocan.mcap", {"/can/rx", "/gnss/fix"})
    cfg = FAST.with_overrides({"output.plots": False, "output.annotations": False})
    result = reprocess(rec, tmp_path / "out", cfg)
    assert result.status == "ok"
    assert "no CAN stream: no CAN speed, yaw rate or Mobileye lane messages" in result.notes
    assert "no curvature ground truth: no GNSS stream" in result.notes
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "no CAN stream" in report
    assert "no curvature ground truth" in report
    frames = pd.read_parquet(tmp_path / "out" / "availability_frames.parquet")
    sup = frames[frames["method"] == "super"]
    assert (~sup["available"]).all()
    assert (sup["reason"].isin(["speed unknown", "no corridor", "too narrow", "too wide"])).all()
    assert (sup["reason"] == "speed unknown").any()
    curv = pd.read_parquet(tmp_path / "out" / "curvature.parquet")
    assert curv["rtk_curvature"].isna().all()


def test_truncated_recording_is_partial(drive: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    data = _copy_mcap(drive, tmp_path / "chunked.mcap", chunk=100_000).read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.6)])
    cfg = FAST.with_overrides({"output.plots": False})
    result = reprocess(cut, tmp_path / "out", cfg)
    assert result.status == "partial"
    assert result.skipped
    assert 0 < result.frames < 60
    assert (tmp_path / "out" / "lanes.parquet").is_file()
    assert (tmp_path / "out" / "report.md").read_text(encoding="utf-8").count("LOST") >= 1


def test_mcap_without_metadata_uses_tf_static(drive: Path, tmp_path: Path) -> None:
    rec = _copy_mcap(drive, tmp_path / "plain.mcap")
    cfg = FAST.with_overrides({"output.plots": False, "output.annotations": False})
    result = reprocess(rec, tmp_path / "out", cfg)
    assert result.frames == 60
    assert any("/tf_static" in note for note in result.notes)
    prov = read_provenance(tmp_path / "out" / "frames.parquet")
    extr = prov["config"]["resolved"]["camera"]["extrinsics"]
    assert math.isclose(extr["height_m"], 1.5, abs_tol=1e-6)
    assert math.isclose(extr["pitch_rad"], 0.06, abs_tol=1e-6)


def test_derived_tables_match_their_schemas(run_dir: Path) -> None:
    """Each derived table as built matches its TableSpec's schema; a drifted builder fails."""
    layout = RunLayout(run_dir)
    tables = {name: pq.read_table(layout.table(name)) for name in DERIVED_TABLES}
    for name, table in tables.items():
        assert checked_table(name, table).num_rows > 0, name
    tracked = set(CURVATURE_SCHEMA.optional.names)  # the tracker ran on this drive
    assert tracked <= set(tables["curvature"].column_names)
    curv = tables["curvature"].to_pandas()
    curv["super_new_curvature"] = 0.0  # a builder that adds a column without declaring it
    with pytest.raises(SchemaMismatchError, match=r"undeclared columns \['super_new_curvature'\]"):
        checked_table("curvature", curv)
    with pytest.raises(SchemaMismatchError, match=r"missing columns \['rtk_valid'\]"):
        checked_table("curvature", curv.drop(columns=["super_new_curvature", "rtk_valid"]))
    summary = tables["curvature_summary"].to_pandas().astype({"n": float})
    with pytest.raises(SchemaMismatchError, match="n is double, declared int64"):
        checked_table("curvature_summary", summary)
    # A drive without Mobileye has an empty table of only its time column: declared, passes.
    empty = tables["mobileye"].select(["log_time_ns"]).slice(0, 0)
    assert checked_table("mobileye", empty).num_rows == 0
