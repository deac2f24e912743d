"""A drive report that tells the whole truth (issue 35 items 1-4 and the report's header).

Real files, reprocessed once per module: a truncated copy of the bundled drive, and a short
simulated drive (640x360, 10 Hz) with every stream, without GNSS, without CAN, and with the
camera only under a camera profile made by ``slt camera estimate`` (widths then circular).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools._version import __version__
from superlane_tools.cli import app
from superlane_tools.commands.reprocess import ReprocessResult, reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.recording.tools import filter_recording
from superlane_tools.simulation.drive import simulate_drive

SAMPLE = Path(__file__).resolve().parents[3] / "fixtures" / "sample_drive.mcap"
FAST = ReprocessConfig().with_overrides(
    {"output.example_frames": 1, "segmentation.backend": "onnx"}
)


def _run(src: Path, out: Path, config: ReprocessConfig = FAST) -> tuple[ReprocessResult, str]:
    result = reprocess(src, out, config)
    return result, (out / "report.md").read_text(encoding="utf-8")


def _section(report: str, title: str) -> str:
    return report.split(f"\n## {title}")[1].split("\n## ", maxsplit=1)[0]


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Path:
    drive = tmp_path_factory.mktemp("sim") / "sim.mcap"
    simulate_drive("highway_curves", 3.0, 35, "mcap", 640, 360, False, drive, fps=10.0)
    return drive


def _without(sim: Path, pattern: str, name: str) -> Path:
    out = sim.with_name(name)
    if not out.exists():
        filter_recording(sim, out, None, pattern)
    return out


@pytest.fixture(scope="module")
def cut_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ReprocessResult, str]:
    """The bundled drive with 4 KiB zeroed at 20 % (a corrupt chunk) and cut at 45 %."""
    folder = tmp_path_factory.mktemp("cut")
    data = bytearray(SAMPLE.read_bytes())
    at = int(len(data) * 0.2)
    data[at : at + 4096] = bytes(4096)
    cut = folder / "sample_cut.mcap"
    cut.write_bytes(bytes(data[: int(len(data) * 0.45)]))
    return (folder / "run", *_run(cut, folder / "run"))


@pytest.fixture(scope="module")
def full_run(sim: Path) -> tuple[Path, ReprocessResult, str]:
    out = sim.parent / "run_full"
    return (out, *_run(sim, out))


@pytest.fixture(scope="module")
def no_gnss_run(sim: Path) -> tuple[Path, ReprocessResult, str]:
    out = sim.parent / "run_no_gnss"
    return (out, *_run(_without(sim, "^/gnss", "no_gnss.mcap"), out))


@pytest.fixture(scope="module")
def no_can_run(sim: Path) -> tuple[Path, ReprocessResult, str]:
    out = sim.parent / "run_no_can"
    return (out, *_run(_without(sim, "^/can", "no_can.mcap"), out))


@pytest.fixture(scope="module")
def estimated_run(sim: Path) -> tuple[Path, ReprocessResult, str]:
    """Camera only (no CAN, no GNSS), camera from ``slt camera estimate`` (assumed lens)."""
    drive = _without(sim, "^/(can|gnss)", "camera_only.mcap")
    profile = sim.parent / "camera_only.estimated.yaml"
    result = CliRunner().invoke(
        app, ["camera", "estimate", str(drive), "--frames", "10", "-o", str(profile)]
    )
    assert result.exit_code == 0, result.output
    out = sim.parent / "run_estimated"
    config = FAST.with_overrides({"camera": str(profile)})
    return (out, *_run(drive, out, config))


# 1. Every percentage has its reason; lost input with what was lost.


def test_headline_names_the_dominant_reason_from_the_frame_table(
    cut_run: tuple[Path, ReprocessResult, str],
) -> None:
    out, _, report = cut_run
    frames = pd.read_parquet(out / "availability_frames.parquet")
    sup = frames[frames["method"] == "super"]
    missed = sup[~sup["available"] & sup["known"]]
    reason, count = (
        missed["reason"].value_counts().index[0],
        missed["reason"].value_counts().iloc[0],
    )
    share = round(100 * int(sup["available"].sum()) / len(sup))
    line = next(ln for ln in _section(report, "Headline").splitlines() if "**Availability:**" in ln)
    unknown = int((~sup["known"]).sum())  # e.g. no CAN speed beside the lost chunk
    expected = f"SUPER {share} % available"
    expected += f" ({unknown} of {len(sup)} frames unknown: no speed)" if unknown else ""
    expected += f": {count} of {len(sup)} frames "
    assert expected in line, line
    if reason == "too short":
        rows = missed[missed["reason"] == reason]
        reach, needed = rows["length_m"].median(), rows["required_length_m"].median()
        assert f"too short (median reach {reach:.1f} m, {needed:.1f} m needed)" in line
    # The section lists every reason with its frames; they add up to the method's frames.
    table = _section(report, "Why frames were not available")
    counts = [int(r.split("|")[3]) for r in table.splitlines() if r.startswith("| SUPER |")]
    assert sum(counts) == len(sup)


def test_lost_input_is_in_the_headline_with_seconds_and_recover(
    cut_run: tuple[Path, ReprocessResult, str],
) -> None:
    out, result, report = cut_run
    assert [s.what for s in result.skipped] == ["corrupt chunk", "truncated file"]
    size = (out.parent / "sample_cut.mcap").stat().st_size
    read = int(re.search(r"byte (\d+)", result.skipped[1].detail).group(1))  # type: ignore[union-attr]
    lost = next(ln for ln in _section(report, "Headline").splitlines() if "Input lost" in ln)
    assert f"read up to byte {read:,} of {size:,}" in lost
    seconds = float(re.search(r"at least about ([0-9.]+) s and (\d+) camera frames", lost)[1])  # type: ignore[index]
    frames = pd.read_parquet(out / "frames.parquet")
    span = (frames["log_time_ns"].max() - frames["log_time_ns"].min()) / 1e9
    assert seconds == pytest.approx(span * (size - read) / read, abs=0.06)
    assert "corrupt chunk (messages lost: unknown): sample_cut.mcap: chunk at byte" in lost
    # The lost chunk inside the drive, measured on the frame times.
    steps = np.diff(np.sort(frames["log_time_ns"].to_numpy())) / 1e9
    period = float(np.median(steps))
    gaps = float(np.sum(steps[steps > 1.5 * period] - period))
    assert gaps > 1.0  # the chunk held about 2 s of the drive
    assert f"{gaps:.1f} s of camera frames missing between the frames read" in lost
    assert "`slt recover sample_cut.mcap -o sample_cut.recovered.mcap`" in lost
    assert "(0)" not in report  # "LOST: truncated file (0)" read as nothing lost
    assert "- LOST: truncated file: read up to byte" in _section(report, "Run")


# 7 (part). Version, command line, date and the model's licence.


def test_report_carries_version_command_date_and_licence(
    cut_run: tuple[Path, ReprocessResult, str],
) -> None:
    out, _, report = cut_run
    head = report.split("\n## ")[0]
    assert f"- tool: superlane-tools {__version__}" in head
    assert "- command: `reprocess('sample_cut.mcap')`" in head  # library call: no argv
    assert re.search(r"- date: \d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC", head)
    assert re.search(r"- model super_seg_v\d: .*CamVid.*CC BY-NC 4\.0", head)
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "CC BY-NC 4.0" in html
    assert f"superlane-tools {__version__}" in html


# 3. Physical limits: RMSE below the noise floor flagged; lengths capped at the camera's range.


def test_rmse_below_the_noise_floor_is_flagged(
    full_run: tuple[Path, ReprocessResult, str],
) -> None:
    out, _, report = full_run
    summary = pd.read_parquet(out / "curvature_summary.parquet")
    overall = summary[summary["scope"] == "overall"]
    floor = float(summary["truth_noise_floor_per_m"].iloc[0])
    below = overall[overall["rmse"] < floor]["source"].tolist()
    section = _section(report, "Curvature against RTK (1/m, left positive)")
    for source in overall["source"]:
        row = next(r for r in section.splitlines() if r.startswith(f"| {source} |"))
        assert ("not resolvable" in row) == (source in below), row
    if below:
        assert "NOT RESOLVABLE" in section


def test_lengths_are_capped_at_the_measurable_range(
    full_run: tuple[Path, ReprocessResult, str],
) -> None:
    from superlane_tools.camera import load_camera
    from superlane_tools.corridor import measurable_range_m

    out, _, report = full_run
    cap = measurable_range_m(load_camera("sim_default").resized(640, 360))
    frames = pd.read_parquet(out / "availability_frames.parquet")
    image = frames[frames["method"].isin(["super", "corridor_net", "hough"])]
    assert image["length_m"].max() <= cap + 1e-9
    capped = re.search(r"measurable range, (\d+) m", report)
    assert capped is None or int(capped[1]) == round(cap)


# 4. Only what applies.


def test_per_drive_values_appear_once(full_run: tuple[Path, ReprocessResult, str]) -> None:
    _, _, report = full_run
    assert "mobileye_latency" not in report  # no column repeating it on every row
    assert "truth_noise_floor_per_m" not in report
    assert report.count("Mobileye latency behind the camera frames") == 1
    headline = _section(report, "Headline")
    assert "truth noise floor (1/m)" not in headline  # said once in the sentence above
    assert "The truth's own noise floor is" in headline


def test_no_gnss_drive_has_no_truth_paragraph_nor_zoom_panel(
    no_gnss_run: tuple[Path, ReprocessResult, str],
) -> None:
    import cv2

    out, _, report = no_gnss_run
    assert "## Curvature (1/m, left positive; no truth)" in report
    assert "Truth: RTK path curvature" not in report
    assert "instants with RTK truth" not in report
    plot = cv2.imread(str(out / "plots" / "curvature_time.png"))
    assert plot.shape[0] < 0.7 * plot.shape[1] * 6.5 / 10  # one panel: no zoom below
    assert not (out / "plots" / "curvature_distance.png").exists()  # no GNSS track


def test_no_can_drive_has_no_mobileye_leftovers(
    no_can_run: tuple[Path, ReprocessResult, str],
) -> None:
    out, result, report = no_can_run
    assert "Mobileye latency" not in report
    assert "Mobileye curvature is 2*C2" not in report
    frames = pd.read_parquet(out / "availability_frames.parquet")
    assert "| mobileye |" not in _section(report, "Availability")
    assert set(frames[frames["method"] == "mobileye"]["reason"].str[:18]) == {"method unavailable"}
    assert "speed: estimated from the GNSS fixes (no CAN stream)" in result.notes


def test_unknown_frames_are_not_outage(
    estimated_run: tuple[Path, ReprocessResult, str],
) -> None:
    out, _, report = estimated_run
    seqs = pd.read_parquet(out / "availability_sequences.parquet")
    sup = seqs[seqs["method"] == "super"].iloc[0]
    assert sup["n_unknown"] == sup["n_frames"]
    assert np.isnan(sup["ratio"])
    assert sup["longest_outage_s"] == 0.0
    row = next(r for r in _section(report, "Availability").splitlines() if "| super |" in r)
    cells = [c.strip() for c in row.split("|")]
    assert cells[7] == "unknown"  # ratio
    assert cells[9] == "unknown"  # longest outage
    assert "SUPER unknown on every frame" in _section(report, "Headline")


# 2. Assumptions are labelled; a circular KPI is not shown as a result.


def test_estimated_camera_values_are_labelled_and_widths_not_shown(
    estimated_run: tuple[Path, ReprocessResult, str],
) -> None:
    _, result, report = estimated_run
    headline = _section(report, "Headline")
    assert "ASSUMED, not measured: lane width 3.7 m" in headline
    assert "circular by construction" in headline
    assert "ASSUMED, not measured: horizontal field of view 60 deg ASSUMED" in headline
    assert "ESTIMATED under an assumption: roll" in headline
    assert "up to 3 degrees of roll (docs/camera.md)" in headline
    assert "**Measured:** corridor lengths of SUPER, the corridor network, Hough (scaled by " in (
        headline
    )
    assert "corridor widths: circular, the camera height was scaled to them" in headline
    availability = _section(report, "Availability")
    assert "median_width_m" not in availability.split("| method |")[1]  # column left out
    assert any("ASSUMED, not measured: lane width" in n for n in result.notes)


def test_report_has_the_timing_detail_the_cli_line_leaves_out(
    full_run: tuple[Path, ReprocessResult, str],
) -> None:
    _, result, report = full_run
    timing = _section(report, "Timing")
    assert re.search(r"- wall: pass \d+\.\d s; process CPU: pass \d+\.\d s", timing)
    assert "per stage, summed over the worker threads (may exceed the wall time):" in timing
    stages = [k for k in result.timings if not k.startswith("cpu_") and "_" not in k[:4]]
    assert any(f"{k} " in timing for k in stages if k not in ("post", "total"))
