"""A label set from mined frames: the drives, their frame scores, and the exported set.

The set: ``images/<drive>_<frame>.jpg`` (the frame at its recorded size) with
``images/<drive>_<frame>.lines.txt`` (CULane pre-annotations, in that image's pixels) beside
each, ``labels.json`` (TuSimple lines, the folder ``slt train --data tusimple=SET`` reads) and
``manifest.parquet`` (drive, recording, time, image size, reasons, scores).
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from superlane_tools.camera.model import CameraModel
from superlane_tools.evaluation.culane import SUFFIX as LINES_SUFFIX
from superlane_tools.evaluation.tusimple import format_record
from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.frames import FrameJpeg, frame_jpegs, gray_frames
from superlane_tools.fleet.label_export import pre_annotation
from superlane_tools.fleet.lighting import lighting_table
from superlane_tools.fleet.mined_spans import drive_ranges
from superlane_tools.fleet.mining import MineParams, candidates, frame_scores
from superlane_tools.fleet.runs import DriveRun, find_drives, read_lanes, read_tables
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_bytes_atomic, write_table
from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.reporting.layout import MineLayout


@dataclass(frozen=True)
class LabelSet:
    """An exported label set: its manifest, what could not be exported, the files written."""

    manifest: pd.DataFrame
    skipped: tuple[Skipped, ...]
    outputs: tuple[Path, ...]


def mined_drives(inputs: Sequence[Path]) -> dict[str, DriveRun]:
    """Return label -> drive of every run under ``inputs`` (a drive of two runs: ``run_drive``).

    Raises:
        FleetError: If an input is not a run, or no drive is found.
    """
    found = [(Path(path).name, d) for path in inputs for d in find_drives(path).drives]
    names = [d.drive for _, d in found]
    by_name = {  # a drive mined from two runs gets its run's name in front
        (f"{run}_{d.drive}" if names.count(d.drive) > 1 else d.drive): d for run, d in found
    }
    if not by_name:
        raise FleetError("empty fleet: no drive with a reprocess run")
    return by_name


def drive_recording(drive: DriveRun, search: Sequence[Path]) -> Path | None:
    """Return the drive's recording: its batch path, else a file of its name under ``search``."""
    direct = Path(drive.recording)
    if direct.exists():
        return direct
    for folder in search:
        found = next(iter(folder.rglob(direct.name)), None) if folder.is_dir() else None
        if found is not None:
            return found
    return None


def _resolved(drive: DriveRun) -> dict[str, Any]:
    config = drive.provenance.get("config") or {}
    return dict(config.get("resolved") or {})


def _frames_topic(drive: DriveRun) -> str:
    return str(_resolved(drive)["streams"]["frames"])


def _unscored(label: str, drive: DriveRun, found: bool, missing: int) -> Skipped:
    """The skipped entry of a drive's frames that got no ``low_light`` score."""
    if not found:
        return Skipped(
            "low_light unscored: recording not found",
            f"{label}: {drive.recording} not found (give --recordings DIR)",
            missing,
        )
    return Skipped("low_light unscored: frame not decodable", label, missing)


def scored_frames(
    drives: dict[str, DriveRun],
    spans: pd.DataFrame,
    params: MineParams,
    recordings: Sequence[Path] = (),
) -> tuple[pd.DataFrame, tuple[Skipped, ...]]:
    """Return every drive's candidate frames with their scores, and the frames left unscored.

    Args:
        drives: Label -> drive (:func:`mined_drives`).
        spans: ``slt compare``'s disagreement spans with content hashes (``read_spans``).
        params: The criteria and their thresholds.
        recordings: Folders to find recordings in (``low_light`` decodes the frames).
    """
    pool, skipped = [], []
    for label, drive in drives.items():
        lighting, recording = None, None
        if "low_light" in params.criteria:
            recording = drive_recording(drive, recordings)
            if recording is not None:
                lighting = lighting_table(gray_frames(recording, _frames_topic(drive)))
        scores = frame_scores(read_tables(drive), drive_ranges(spans, drive), params, lighting)
        if "low_light" in params.criteria and (missing := int(scores["low_light"].isna().sum())):
            skipped.append(_unscored(label, drive, lighting is not None, missing))
        pool.append(candidates(scores, params).assign(drive=label))
    return pd.concat(pool, ignore_index=True), tuple(skipped)


def export_label_set(
    picks: pd.DataFrame,
    drives: dict[str, DriveRun],
    out: Path,
    params: MineParams,
    provenance: Provenance,
    recordings: Sequence[Path] = (),
) -> LabelSet:
    """Write the picked frames, their pre-annotations, ``labels.json`` and the manifest.

    Args:
        picks: The picked frames (``select_frames``): drive label, frame, time, reasons, scores.
        drives: Label -> drive.
        out: The label set's folder.
        params: The criteria (their scores are manifest columns).
        provenance: Provenance of the manifest.
        recordings: Folders to find recordings in.
    """
    layout = MineLayout(out)
    written: list[Path] = []
    labels: list[str] = []
    rows: list[dict[str, Any]] = []
    skipped: list[Skipped] = []
    for name, group in picks.groupby("drive", sort=True):
        drive = drives[str(name)]
        recording = drive_recording(drive, recordings)
        if recording is None:
            skipped.append(
                Skipped(
                    "frames without their recording",
                    f"{name}: {drive.recording} not found (give --recordings DIR)",
                    len(group),
                )
            )
            continue
        times = set(group["log_time_ns"].astype(int))
        images = frame_jpegs(recording, _frames_topic(drive), times)
        fits = read_lanes(drive).set_index("frame_index", drop=False)
        camera = CameraModel.from_dict(_resolved(drive)["camera"])
        for pick in group.to_dict("records"):
            index, t_ns = int(pick["frame_index"]), int(pick["log_time_ns"])
            jpeg = images.get(t_ns)
            if jpeg is None:
                skipped.append(Skipped("undecodable frame", f"{name} frame {index}"))
                continue
            fit = {str(k): v for k, v in fits.loc[index].to_dict().items()}
            raw = f"{layout.images.name}/{name}_{index:06d}.jpg"
            labels.append(_write_frame(out, raw, jpeg, fit, camera, written))
            rows.append(_manifest_row(str(name), recording, raw, pick, jpeg, params))
    manifest = pd.DataFrame(rows)
    written.append(write_text_atomic(layout.labels, "".join(f"{t}\n" for t in labels)))
    written.append(write_table(manifest, layout.manifest, provenance))
    return LabelSet(manifest, tuple(skipped), tuple(written))


def _write_frame(
    out: Path,
    raw: str,
    jpeg: FrameJpeg,
    fit: dict[str, Any],
    camera: CameraModel,
    written: list[Path],
) -> str:
    """Write a frame's image and CULane lines (into ``written``); return its TuSimple line."""
    written.append(write_bytes_atomic(out / raw, jpeg.data))
    record, lines = pre_annotation(fit, camera, raw, (jpeg.width, jpeg.height))
    written.append(write_text_atomic(out / raw.replace(".jpg", LINES_SUFFIX), lines))
    return format_record(record)


def _manifest_row(
    drive: str,
    recording: Path,
    image: str,
    pick: Mapping[Hashable, Any],
    jpeg: FrameJpeg,
    params: MineParams,
) -> dict[str, Any]:
    return {
        "drive": drive,
        "recording": str(recording),
        "image": image,
        "frame_index": int(pick["frame_index"]),
        "log_time_ns": int(pick["log_time_ns"]),
        "width": jpeg.width,
        "height": jpeg.height,
        "reasons": str(pick["reasons"]),
        "score": float(pick["score"]),
        **{c: float(pick[c]) for c in params.criteria},
    }
