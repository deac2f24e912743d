"""The report of one reprocessed drive: headline, run, curvature, availability, examples.

Sections show only what was measured: a method or curvature source that did not run on this
drive is left out of the tables (the plots leave it out too), and each section first says what
it could not evaluate and why (:mod:`~superlane_tools.reporting.drive_notes`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from superlane_tools.records import Skipped
from superlane_tools.reporting.availability_reasons import reasons_table
from superlane_tools.reporting.drive_facts import DriveFacts
from superlane_tools.reporting.drive_notes import (
    assumption_notes,
    availability_gaps,
    capped_note,
    curvature_gaps,
    inputs_line,
    lost_lines,
    recover_hint,
    unlike_training_data,
)
from superlane_tools.reporting.headline import below_floor, headline_table, rmse_cell
from superlane_tools.reporting.names import CURVATURE_NAMES
from superlane_tools.reporting.report import Section

if TYPE_CHECKING:
    import pandas as pd


@dataclass(frozen=True)
class ReportFacts:
    """What the report states about the run besides the tables.

    Attributes:
        recording: The input recording.
        n_frames: Frames processed (evaluation instants without a camera).
        backend_name: Segmentation backend used.
        corridor_unavailable: Why the corridor network is unavailable ("" when available).
        notes: Stream choice, camera, fallbacks and the drive's notes, in order.
        skipped: What was lost.
        implausible: Why no segmentation backend gave plausible lanes on this drive (the
            per-drive self-check; "" when one did, or when it did not run).
        header: The report's opening lines: tool version, command line, date, model licences.
        input_bytes: Size of the recording, bytes (0 unknown): what a truncation lost.
        timing: The pass's measured times in one line (wall, process CPU, per stage summed
            over the worker threads): the detail behind the CLI's short ``times:`` line.
    """

    recording: Path
    n_frames: int
    backend_name: str
    corridor_unavailable: str
    notes: tuple[str, ...]
    skipped: tuple[Skipped, ...]
    implausible: str = ""
    header: tuple[str, ...] = ()
    input_bytes: int = 0
    timing: str = ""


@dataclass(frozen=True)
class ReportSettings:
    """The configuration values the report quotes (windows, thresholds, tracker)."""

    truth_window_m: float
    tracking: bool
    fit_noise: bool
    min_width_m: float
    max_width_m: float
    time_gap_s: float
    window_s: float
    max_outage_s: float
    width_at_m: float


class SectionTables(NamedTuple):
    """The drive tables the report shows."""

    curvature: pd.DataFrame
    curvature_summary: pd.DataFrame
    availability_sequences: pd.DataFrame


AVAILABILITY_COLUMNS = [
    "method",
    "sequence",
    "category",
    "n_frames",
    "n_available",
    "n_unknown",
    "ratio",
    "available",
    "longest_outage_s",
    "median_width_m",
]
UNTRACKED_PATH = (
    "2*a2 placed at the middle of the ego lines' supported range ahead and read back at the "
    "vehicle's arc length, smoothed with the truth's filter, plus the second derivative along "
    "the path of the vehicle's lateral position in its lane."
)


def drive_sections(
    settings: ReportSettings,
    run: ReportFacts,
    facts: DriveFacts,
    tables: SectionTables,
    images: Sequence[str],
) -> list[Section]:
    """Return the report's sections: headline, run, curvature, availability, examples."""
    summary = tables.curvature_summary
    floor = float(summary["truth_noise_floor_per_m"].iloc[0]) if len(summary) else float("nan")
    degraded = bool(summary["truth_degraded"].iloc[0]) if len(summary) else False
    headline = Section(
        "Headline",
        [
            *([f"**{unlike_training_data(run.implausible)}**", ""] if run.implausible else []),
            inputs_line(facts),
            "",
            *_lost_paragraph(run, facts),
            *_why_paragraph(facts),
            *_paragraphs([f"**{note}**" for note in assumption_notes(facts)]),
            "One number per method that ran: curvature RMSE against the same truth (1/m; the "
            "path methods get the same placement, smoothing and manoeuvre term) and "
            "availability (frames and sequences, see Availability; `unknown`: no speed to "
            "judge the corridor length)."
            + _floor_sentence(facts, floor)
            + (" Truth degraded: not RTK (plain GNSS fixes)." if degraded else ""),
        ],
        [headline_table(summary, tables.availability_sequences, floor, facts)],
    )
    return [
        headline,
        _run_section(run, facts),
        _curvature_section(settings, facts, tables, images),
        _availability_section(settings, facts, tables.availability_sequences, images),
        *_reasons_section(facts),
        *_examples_section(facts, images),
        *([Section("Timing", [f"- {run.timing}"])] if run.timing else []),
    ]


def _lost_paragraph(run: ReportFacts, facts: DriveFacts) -> list[str]:
    """The headline's statement of lost input ([] when nothing was lost)."""
    if not run.skipped:
        return []
    lost = "; ".join(lost_lines(run.skipped, run.input_bytes, facts))
    hint = recover_hint(run.recording, run.skipped)
    return [f"**Input lost:** {lost}." + (f" {hint}" if hint else ""), ""]


def _why_paragraph(facts: DriveFacts) -> list[str]:
    """Each method's share of available frames and the dominant reason of the others."""
    if not facts.availability:
        return []
    return ["**Availability:** " + "; ".join(m.summary() for m in facts.availability) + ".", ""]


def _floor_sentence(facts: DriveFacts, floor: float) -> str:
    if not facts.truth_instants:
        return ""
    if math.isfinite(floor):
        return (
            f" The truth's own noise floor is {floor:.3g} 1/m: no RMSE can be read below it "
            "(such RMSEs are flagged not resolvable)."
        )
    return " The truth's noise floor is unknown."


def _run_section(run: ReportFacts, facts: DriveFacts) -> Section:
    lost = [f"- LOST: {line}" for line in lost_lines(run.skipped, run.input_bytes, facts)]
    if hint := recover_hint(run.recording, run.skipped):
        lost.append(f"- {hint}")
    frames = (
        f"- camera frames: {run.n_frames}"
        if facts.camera
        else f"- camera frames: none; evaluation instants: {facts.n_instants}"
    )
    lines = [frames]
    if facts.camera:
        lines += [
            f"- segmentation backend: {run.backend_name}",
            f"- corridor network: {run.corridor_unavailable or 'ran'}",
        ]
    return Section("Run", [*lines, *[f"- {note}" for note in run.notes], *lost])


def _curvature_section(
    settings: ReportSettings, facts: DriveFacts, tables: SectionTables, images: Sequence[str]
) -> Section:
    summary, curv = tables.curvature_summary, tables.curvature
    lines = [*_paragraphs(curvature_gaps(facts)), *_curvature_paragraph(settings, facts)]
    if facts.gnss:
        lines.append(
            f"- instants with RTK truth: {int(curv['rtk_curvature'].notna().sum())} of "
            f"{facts.n_instants}"
        )
    shown: list[pd.DataFrame] = []
    if facts.truth_instants and len(summary):
        ran = summary["source"].isin(facts.curvature_sources_run())
        overall = summary[(summary["scope"] == "overall") & ran]
        floor = float(summary["truth_noise_floor_per_m"].iloc[0])
        lines += _below_floor_lines(overall, floor)
        per_drive = [c for c in PER_DRIVE_COLUMNS if c in overall.columns]
        table = overall.drop(columns=["scope", "category", "start", "stop", *per_drive])
        table["rmse"] = [rmse_cell(float(v), floor) for v in table["rmse"]]
        shown = [table]
    has_curve = bool(facts.truth_instants or facts.curvature_sources_run())
    plots = [i for i in images if "curvature" in i] if has_curve else []
    title = "Curvature against RTK (1/m, left positive)"
    if not facts.truth_instants:
        title = "Curvature (1/m, left positive; no truth)"
    return Section(title, lines, shown, plots)


PER_DRIVE_COLUMNS = (
    "truth_noise_floor_per_m",
    "truth_degraded",
    "mobileye_latency_s",
    "mobileye_latency_resolved",
)
"""Columns of ``curvature_summary`` that hold one value per drive: stated once, not per row."""


def _below_floor_lines(overall: pd.DataFrame, floor: float) -> list[str]:
    """One line naming the sources whose RMSE lies below the truth's noise floor."""
    below = [
        f"`{src}` {float(r):.3g}"
        for src, r in zip(overall["source"], overall["rmse"], strict=True)
        if below_floor(float(r), floor)
    ]
    if not below:
        return []
    return [
        f"- NOT RESOLVABLE: {', '.join(below)} 1/m: below the truth's own noise floor "
        f"{floor:.3g} 1/m; the truth cannot tell these errors apart from zero."
    ]


def _curvature_paragraph(settings: ReportSettings, facts: DriveFacts) -> list[str]:
    """What the truth and each estimate are: only those that exist on this drive."""
    text = []
    if facts.truth_instants:
        text.append(
            "Truth: RTK path curvature at the vehicle (Savitzky-Golay over "
            f"{settings.truth_window_m} m of arc length, degraded fixes excluded)."
        )
    if facts.camera:
        text.append(
            "`super` is the fit's raw 2*a2 at the frame time: the curvature of a quadratic "
            "over the lines' supported range ahead, so it describes the road about half that "
            "range ahead and leaves out the vehicle's own lateral manoeuvres. `super_path` is "
            "the like-for-like estimate of the path curvature at the vehicle, `super_road` the "
            f"same without the vehicle's lateral manoeuvres; {_path_method(settings)}"
        )
    if facts.mobileye:
        text.append(
            "Mobileye curvature is 2*C2 (defined at the vehicle) with its sign flipped into the "
            "left-positive lane model convention."
        )
    if facts.dynamics:
        text.append(f"{CURVATURE_NAMES['dynamics']}: the yaw rate over the speed.")
    return [" ".join(text)] if text else []


def _availability_section(
    settings: ReportSettings, facts: DriveFacts, av_seqs: pd.DataFrame, images: Sequence[str]
) -> Section:
    circular = facts.widths_circular
    lines = [
        *_paragraphs(availability_gaps(facts)),
        f"Available: corridor width in [{settings.min_width_m}, {settings.max_width_m}] m and "
        f"length >= speed * {settings.time_gap_s} s. Sequences: {settings.window_s} s "
        f"windows (or manifest segments); a sequence is available with no outage longer than "
        f"{settings.max_outage_s:.3g} s (dropped frames count as outage, frames of unknown "
        "availability do not). Columns: "
        "`n_frames` frames in the sequence, `n_available` frames available, `n_unknown` frames "
        "whose availability is unknown (no speed), `ratio` = n_available / n_frames "
        "(`unknown` when every frame is), `available` the sequence decision (empty: decided by "
        "unknown frames), `longest_outage_s` the longest outage of frames known to be "
        "unavailable, "
        + (
            "`median_width_m` left out: widths are circular (the camera height was scaled to an "
            "assumed lane width, see Headline). "
            if circular
            else "`median_width_m` the median corridor width. "
        )
        + "Only the methods that ran on this drive are listed. Every method's width is measured "
        f"{settings.width_at_m:g} m ahead (`kpi.width_at_m`; at the corridor's far end when "
        "it is shorter), and widths and lengths are measured from one origin, the camera's "
        "vehicle frame (the camera foot with default extrinsics): SUPER between its fitted ego "
        "lines, the corridor network from its mask projected to the ground, the Hough baseline "
        "between its two lines, Mobileye between its two lines (both quality >= 2; its own "
        "camera taken at that origin), length = its view range.",
    ]
    if note := capped_note(facts):
        lines += ["", note]
    ran = facts.methods_run()
    shown = []
    if ran and not av_seqs.empty:
        rows = av_seqs[av_seqs["method"].isin(ran)]
        if len(rows):
            shown = [_sequence_rows(rows, circular)]
    plots = [i for i in images if "availability" in i] if ran else []
    return Section("Availability", lines, shown, plots)


def _reasons_section(facts: DriveFacts) -> list[Section]:
    """Each method's frames by state: available, not available for each reason, unknown."""
    if not facts.availability:
        return []
    text = (
        "Every frame of each method that ran, by state: available, not available and why "
        "(`too short`: the corridor's median reach against the median length needed at the "
        "speed; `too narrow` / `too wide`: the median width against the bound), or unknown (no "
        "speed). Frames and their share of the method's frames."
    )
    return [Section("Why frames were not available", [text], [reasons_table(facts.availability)])]


def _sequence_rows(rows: pd.DataFrame, circular: bool) -> pd.DataFrame:
    """The sequence table as shown: all-unknown sequences say so; circular widths left out."""
    columns = [c for c in AVAILABILITY_COLUMNS if not (circular and c == "median_width_m")]
    table = rows[columns].astype(object)
    all_unknown = (rows["n_unknown"] >= rows["n_frames"]).to_numpy()
    for column in ("ratio", "longest_outage_s"):
        table.loc[all_unknown, column] = "unknown"
    return table


def _examples_section(facts: DriveFacts, images: Sequence[str]) -> list[Section]:
    if not facts.camera:
        return []
    return [
        Section(
            "Example frames",
            [
                "Segmentation, BEV lane pixels, offset histogram "
                "with peaks, fitted lanes (colour and style)."
            ],
            (),
            [i for i in images if "example" in i],
        )
    ]


def _paragraphs(texts: Iterable[str]) -> list[str]:
    """Markdown lines that keep each text its own paragraph (the HTML writer skips blanks)."""
    return [line for text in texts for line in (text, "")]


def _path_method(settings: ReportSettings) -> str:
    """How ``super_road`` / ``super_path`` were made, for the report."""
    if not settings.tracking:
        return f"both come from {UNTRACKED_PATH}"
    noise = "the fit's own covariance" if settings.fit_noise else "fixed noise levels"
    return (
        "both come from the lane tracker (Kalman filter and smoother over the distance travelled "
        f"on each frame's -a1, 2*a2 and slope, with {noise} and the look-ahead in the "
        "measurement model), smoothed with the truth's filter. `super_road_sg` / "
        f"`super_path_sg` are the untracked estimates: {UNTRACKED_PATH}"
    )
