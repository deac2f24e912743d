"""``slt mine RUN_OR_ROOT... -o SET``: score frames, pick spread-out ones, export a label set.

The set: ``images/<drive>_<frame>.jpg`` (the frame at its recorded size) with
``images/<drive>_<frame>.lines.txt`` (CULane pre-annotations, in that image's pixels) beside
each, ``labels.json`` (TuSimple lines, the folder ``slt train --data tusimple=SET`` reads) and
``manifest.parquet`` (drive, recording, time, image size, reasons, scores).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from superlane_tools.camera.model import CameraModel
from superlane_tools.commands.mine.spans import drive_ranges, read_spans
from superlane_tools.evaluation.culane import SUFFIX as CULANE_SUFFIX
from superlane_tools.evaluation.tusimple import format_record
from superlane_tools.fleet import DriveRun, FleetError, find_drives, read_tables
from superlane_tools.fleet.frames import frame_jpegs, gray_frames
from superlane_tools.fleet.label_export import pre_annotation
from superlane_tools.fleet.lighting import lighting_table
from superlane_tools.fleet.mining import MineParams, candidates, frame_scores, select_frames
from superlane_tools.fleet.runs import read_lanes
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_bytes_atomic, write_table
from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.reporting.layout import MineLayout

LINES_SUFFIX = CULANE_SUFFIX


@dataclass(frozen=True)
class MineResult:
    """The picked frames (the manifest), what was skipped, and the files written."""

    manifest: pd.DataFrame
    skipped: tuple[Skipped, ...]
    outputs: tuple[Path, ...]


def _recording(drive: DriveRun, search: Sequence[Path]) -> Path | None:
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


def _lighting(drive: DriveRun, recordings: Sequence[Path]) -> pd.DataFrame | None:
    """The drive's per-frame ``low_light`` statistics, or None without its recording."""
    recording = _recording(drive, recordings)
    if recording is None:
        return None
    topic = str(_resolved(drive)["streams"]["frames"])
    return lighting_table(gray_frames(recording, topic))


def _unscored(label: str, drive: DriveRun, found: bool, missing: int) -> Skipped:
    """The skipped entry of a drive's frames that got no ``low_light`` score."""
    if not found:
        return Skipped(
            "low_light unscored: recording not found",
            f"{label}: {drive.recording} not found (give --recordings DIR)",
            missing,
        )
    return Skipped("low_light unscored: frame not decodable", label, missing)


def mine_runs(
    inputs: Sequence[Path],
    out: Path,
    params: MineParams,
    recordings: Sequence[Path] = (),
    compare_dir: Path | None = None,
    command: str = "",
) -> MineResult:
    """Pick frames worth labelling from runs and export them as a label set under ``out``.

    Raises:
        FleetError: If an input is not a run, or no drive is found.
    """
    found = [(Path(path).name, d) for path in inputs for d in find_drives(path).drives]
    names = [d.drive for _, d in found]
    by_name = {  # a drive mined from two runs gets its run's name in front
        (f"{run}_{d.drive}" if names.count(d.drive) > 1 else d.drive): d for run, d in found
    }
    drives = list(by_name.values())
    if not drives:
        raise FleetError("empty fleet: no drive with a reprocess run")
    spans = read_spans(compare_dir)
    layout = MineLayout(out)
    pool = []
    skipped: list[Skipped] = []
    for label, drive in by_name.items():
        ranges = drive_ranges(spans, drive)
        lit = "low_light" in params.criteria
        lighting = _lighting(drive, recordings) if lit else None
        scores = frame_scores(read_tables(drive), ranges, params, lighting)
        if lit and (missing := int(scores["low_light"].isna().sum())):
            skipped.append(_unscored(label, drive, lighting is not None, missing))
        pool.append(candidates(scores, params).assign(drive=label))
    picks = select_frames(pd.concat(pool, ignore_index=True), params)
    written: list[Path] = []
    labels, rows = [], []
    for name, group in picks.groupby("drive", sort=True):
        drive = by_name[str(name)]
        resolved = _resolved(drive)
        recording = _recording(drive, recordings)
        if recording is None:
            skipped.append(
                Skipped(
                    "frames without their recording",
                    f"{name}: {drive.recording} not found (give --recordings DIR)",
                    len(group),
                )
            )
            continue
        camera = CameraModel.from_dict(resolved["camera"])
        times = set(group["log_time_ns"].astype(int))
        images = frame_jpegs(recording, str(resolved["streams"]["frames"]), times)
        fits = read_lanes(drive).set_index("frame_index", drop=False)
        for pick in group.to_dict("records"):
            index, t_ns = int(pick["frame_index"]), int(pick["log_time_ns"])
            jpeg = images.get(t_ns)
            if jpeg is None:
                skipped.append(Skipped("undecodable frame", f"{name} frame {index}"))
                continue
            raw = f"{layout.images.name}/{name}_{index:06d}.jpg"
            written.append(write_bytes_atomic(out / raw, jpeg.data))
            fit = {str(k): v for k, v in fits.loc[index].to_dict().items()}
            record, lines = pre_annotation(fit, camera, raw, (jpeg.width, jpeg.height))
            written.append(write_text_atomic(out / raw.replace(".jpg", LINES_SUFFIX), lines))
            labels.append(format_record(record))
            rows.append(
                {
                    "drive": name,
                    "recording": str(recording),
                    "image": raw,
                    "frame_index": index,
                    "log_time_ns": t_ns,
                    "width": jpeg.width,
                    "height": jpeg.height,
                    "reasons": str(pick["reasons"]),
                    "score": float(pick["score"]),
                    **{c: float(pick[c]) for c in params.criteria},
                }
            )
    manifest = pd.DataFrame(rows)
    written.append(write_text_atomic(layout.labels, "".join(f"{t}\n" for t in labels)))
    provenance = Provenance(
        command=command or "slt mine",
        config={
            "criteria": list(params.criteria),
            "require_all": params.require_all,
            "max_frames": params.max_frames,
            "max_per_drive": params.max_per_drive,
            "min_gap_s": params.min_gap_s,
        },
    )
    written.append(write_table(manifest, layout.manifest, provenance))
    return MineResult(manifest, tuple(skipped), tuple(written))
