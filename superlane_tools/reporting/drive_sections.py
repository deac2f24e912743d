"""The report of one reprocessed drive: headline, run, curvature, availability, examples.

Sections show only what was measured: a method or curvature source that did not run on this
drive is left out of the tables (the plots leave it out too), and each section first says what
it could not evaluate and why (:mod:`~superlane_tools.reporting.drive_notes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from superlane_tools.records import Skipped
from superlane_tools.reporting.drive_facts import DriveFacts
from superlane_tools.reporting.drive_notes import (
    availability_gaps,
    curvature_gaps,
    inputs_line,
    unlike_training_data,
)
from superlane_tools.reporting.headline import headline_table
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
    """

    recording: Path
    n_frames: int
    backend_name: str
    corridor_unavailable: str
    notes: tuple[str, ...]
    skipped: tuple[Skipped, ...]
    implausible: str = ""


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
            "One number per method that ran: curvature RMSE against the same truth (1/m; the "
            "path methods get the same placement, smoothing and manoeuvre term) and "
            "availability (frames and sequences, see Availability; `unknown`: no speed to "
            "judge the corridor length). No RMSE can be read below the truth's own noise floor."
            + (" Truth degraded: not RTK (plain GNSS fixes)." if degraded else ""),
        ],
        [headline_table(summary, tables.availability_sequences, floor, facts)],
    )
    return [
        headline,
        _run_section(run, facts),
        _curvature_section(settings, facts, tables, images),
        _availability_section(settings, facts, tables.availability_sequences, images),
        *_examples_section(facts, images),
    ]


def _run_section(run: ReportFacts, facts: DriveFacts) -> Section:
    lost = [f"- LOST: {s.what} ({s.n_items}): {s.detail}" for s in run.skipped]
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
    lines = [
        *_paragraphs(curvature_gaps(facts)),
        "Truth: RTK path curvature at the vehicle (Savitzky-Golay over "
        f"{settings.truth_window_m} m of arc length, degraded fixes excluded). "
        "`super` is the fit's raw 2*a2 at the frame time: the curvature of a quadratic over "
        "the lines' supported range ahead, so it describes the road about half that range "
        "ahead and leaves out the vehicle's own lateral manoeuvres. `super_path` is the "
        "like-for-like estimate of the path curvature at the vehicle, `super_road` the "
        f"same without the vehicle's lateral manoeuvres; {_path_method(settings)} "
        "Mobileye curvature is 2*C2 (defined at the vehicle) with its sign flipped into the "
        "left-positive lane model convention.",
        f"- instants with RTK truth: {int(curv['rtk_curvature'].notna().sum())} of "
        f"{facts.n_instants}",
    ]
    shown: list[pd.DataFrame] = []
    if facts.truth_instants and len(summary):
        ran = summary["source"].isin(facts.curvature_sources_run())
        overall = summary[(summary["scope"] == "overall") & ran]
        shown = [overall.drop(columns=["scope", "category", "start", "stop"])]
    has_curve = bool(facts.truth_instants or facts.curvature_sources_run())
    plots = [i for i in images if "curvature" in i] if has_curve else []
    return Section("Curvature against RTK (1/m, left positive)", lines, shown, plots)


def _availability_section(
    settings: ReportSettings, facts: DriveFacts, av_seqs: pd.DataFrame, images: Sequence[str]
) -> Section:
    lines = [
        *_paragraphs(availability_gaps(facts)),
        f"Available: corridor width in [{settings.min_width_m}, {settings.max_width_m}] m and "
        f"length >= speed * {settings.time_gap_s} s. Sequences: {settings.window_s} s "
        f"windows (or manifest segments); a sequence is available with no outage longer than "
        f"{settings.max_outage_s:.3g} s (dropped frames count as outage). Columns: "
        "`n_frames` frames in the sequence, `n_available` frames available, `n_unknown` frames "
        "whose availability is unknown (no speed), `ratio` = n_available / n_frames, "
        "`available` the sequence decision (empty: decided by unknown frames), "
        "`longest_outage_s` the longest outage, `median_width_m` the median corridor width. "
        "Only the methods that ran on this drive are listed. Every method's width is measured "
        f"{settings.width_at_m:g} m ahead (`kpi.width_at_m`; at the corridor's far end when "
        "it is shorter), and widths and lengths are measured from one origin, the camera's "
        "vehicle frame (the camera foot with default extrinsics): SUPER between its fitted ego "
        "lines, the corridor network from its mask projected to the ground, the Hough baseline "
        "between its two lines, Mobileye between its two lines (both quality >= 2; its own "
        "camera taken at that origin), length = its view range.",
    ]
    ran = facts.methods_run()
    shown = []
    if ran and not av_seqs.empty:
        rows = av_seqs[av_seqs["method"].isin(ran)]
        if len(rows):
            shown = [rows[AVAILABILITY_COLUMNS]]
    plots = [i for i in images if "availability" in i] if ran else []
    return Section("Availability", lines, shown, plots)


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


def _paragraphs(texts: Sequence[str]) -> list[str]:
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
