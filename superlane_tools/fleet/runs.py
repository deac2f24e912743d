"""Find the drives of a run folder, a folder of run folders or a batch root, and read their tables.

File names and columns come from the tables' specs in :mod:`superlane_tools.reporting.layout`.
A drive's match key is the content hash of its recording (the provenance's first input, or the
batch status's ``content_hash``) plus its batch window, so the same recording matches across run
folders and batch roots wherever it was stored.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.kpis import DriveTables
from superlane_tools.records import Skipped
from superlane_tools.reporting.errors import OutputError
from superlane_tools.reporting.layout import (
    AVAILABILITY_FRAMES_TABLE,
    AVAILABILITY_SEQUENCES_TABLE,
    BATCH_STATUS_TABLE,
    CURVATURE_TABLE,
    FRAMES_TABLE,
    LANES_TABLE,
    MANIFEST_FILE,
    BatchLayout,
    RunLayout,
)
from superlane_tools.reporting.parquet import read_provenance
from superlane_tools.reporting.run_folder import require_complete_run

UNCATEGORISED = "uncategorised"
_AF, _AS, _CURV = AVAILABILITY_FRAMES_TABLE, AVAILABILITY_SEQUENCES_TABLE, CURVATURE_TABLE
REQUIRED_COLUMNS: Mapping[str, tuple[str, ...]] = {
    _AF.name: _AF.pick("frame_index", "log_time_ns", "method", "width_m", "available"),
    _AS.name: _AS.pick(
        "sequence",
        "start",
        "stop",
        "start_ns",
        "method",
        "n_frames",
        "n_available",
        "available",
    ),
    _CURV.name: _CURV.pick("frame_index", "log_time_ns"),
    LANES_TABLE.name: LANES_TABLE.pick(
        "frame_index", "log_time_ns", "ego_left", "ego_right", "cost"
    ),
    FRAMES_TABLE.name: FRAMES_TABLE.pick("frame_index", "log_time_ns"),
}
"""Columns each table must have for the KPIs (tables of other tool versions may lack some),
checked against the tables' specs when this module loads."""
OPTIONAL_COLUMNS: Mapping[str, tuple[str, ...]] = {
    _AF.name: _AF.pick("known"),
    _AS.name: _AS.pick("category", "method_available"),
    _CURV.name: _CURV.pick(
        "rtk_curvature",
        "rtk_valid",
        "dynamics_curvature",
        "super_curvature",
        "super_path_curvature",
        "super_lateral_m",
    ),
    LANES_TABLE.name: LANES_TABLE.pick("quality"),
    FRAMES_TABLE.name: (),
}
"""Columns read where present; only these are read (a fleet's tables stay small in memory)."""
CPU_MS_SUFFIX = "_cpu_ms"


@dataclass(frozen=True)
class DriveRun:
    """One drive of a run: where its tables are and how it is matched.

    Attributes:
        key: Match key (recording content hash, plus the batch window if any).
        drive: Display id (batch recording id, or the run folder's name).
        folder: The run folder.
        category: The drive's category (batch status; else ``uncategorised``).
        recording: The recording's path where known (batch status), else its file name.
        provenance: The provenance of the run's availability table.
    """

    key: str
    drive: str
    folder: Path
    category: str
    recording: str
    provenance: Mapping[str, Any] = field(repr=False)

    @property
    def annotations(self) -> Path:
        """Return the run's annotations MCAP (for Foxglove)."""
        return RunLayout(self.folder).annotations

    @property
    def tool_version(self) -> str:
        """Return the version of the tool that wrote the run."""
        return str(self.provenance.get("tool_version", ""))


@dataclass(frozen=True)
class Fleet:
    """The drives found under one path, and what was skipped there."""

    root: Path
    kind: str
    drives: tuple[DriveRun, ...]
    skipped: tuple[Skipped, ...] = ()


def _provenance(folder: Path) -> dict[str, Any]:
    try:
        return read_provenance(RunLayout(folder).availability_sequences)
    except OutputError as err:
        raise FleetError(f"{folder}: not a reprocess run ({err})") from err


def _run_drive(
    folder: Path,
    drive: str,
    category: str = "",
    recording: str = "",
    window: str = "",
    content_hash: str = "",
) -> DriveRun:
    prov = _provenance(folder)
    inputs = prov.get("inputs") or []
    first = inputs[0] if inputs and isinstance(inputs[0], Mapping) else {}
    content = content_hash or str(first.get("content_hash", "")) or f"folder:{folder.name}"
    return DriveRun(
        key=f"{content}|{window}" if window else content,
        drive=drive,
        folder=folder,
        category=category or UNCATEGORISED,
        recording=recording or str(first.get("name", "")),
        provenance=prov,
    )


def _is_run(folder: Path) -> bool:
    layout = RunLayout(folder)
    return layout.manifest.is_file() and layout.availability_sequences.is_file()


def _batch_root(root: Path) -> Fleet:
    try:
        status = pd.read_parquet(BatchLayout(root).batch_status)
    except (OSError, pa.ArrowException, ValueError) as err:
        raise FleetError(f"{root}: unreadable {BATCH_STATUS_TABLE.file}: {err}") from err
    drives, skipped = [], []
    for row in status.itertuples(index=False):
        rid = str(row.recording_id)
        folder = root / rid
        result = str(getattr(row, "result", "")) or str(row.status)
        if result not in ("ok", "partial") or not _is_run(folder):
            why = str(getattr(row, "error", "")) or f"no reprocess run ({result or 'unknown'})"
            skipped.append(Skipped("drive without a run", f"{rid}: {why}"))
            continue
        window = "|".join(str(getattr(row, c, "")) for c in ("sequence", "start_s", "end_s"))
        window = "" if window in ("||", "|nan|nan", "|None|None") else window
        drives.append(
            _run_drive(
                folder,
                rid,
                str(row.category),
                str(row.recording),
                window,
                str(getattr(row, "content_hash", "") or ""),
            )
        )
    return Fleet(root, "batch root", tuple(drives), tuple(skipped))


def find_drives(path: str | Path) -> Fleet:
    """Return the drives under ``path``: a run folder, a folder of run folders or a batch root.

    Raises:
        FleetError: If ``path`` is none of these (naming what it lacks), or a run folder is
            incomplete (killed or failed run).
    """
    root = Path(path)
    if root.is_file():
        raise FleetError(
            f"{root}: not a reprocess run folder: run slt reprocess first (`slt reprocess "
            f"{root}` writes runs/<name>/), or give a batch root"
        )
    if not root.is_dir():
        raise FleetError(f"{root}: no such folder (expected a reprocess run or a batch root)")
    try:
        if (root / MANIFEST_FILE).is_file():
            require_complete_run(root)
            if not _is_run(root):
                raise FleetError(
                    f"{root}: a run folder without {RunLayout(root).availability_sequences.name} "
                    "(not a reprocess run)"
                )
            return Fleet(root, "run folder", (_run_drive(root, root.name),))
        if BatchLayout(root).batch_status.is_file():
            return _batch_root(root)
        runs = sorted(p for p in root.iterdir() if p.is_dir() and _is_run(p))
        for run in runs:
            require_complete_run(run)
    except OutputError as err:
        raise FleetError(str(err)) from err
    if not runs:
        raise FleetError(
            f"{root}: not a reprocess run folder: run slt reprocess first (no {MANIFEST_FILE}; "
            f"nor a batch root with {BATCH_STATUS_TABLE.file}, nor a folder of run folders)"
        )
    return Fleet(root, "folder of runs", tuple(_run_drive(r, r.name) for r in runs))


def read_tables(run: DriveRun) -> DriveTables:
    """Read the tables the KPIs need from a drive's run folder.

    Raises:
        FleetError: If a table is missing, unreadable or lacks a needed column (a run of an
            incompatible tool version: the message names the version).
    """
    frames: dict[str, pd.DataFrame] = {}
    for key, columns in REQUIRED_COLUMNS.items():
        path = RunLayout(run.folder).table(key)
        try:
            present = pq.read_schema(path).names
            wanted = [*columns, *OPTIONAL_COLUMNS[key]]
            wanted += [c for c in present if key == FRAMES_TABLE.name and c.endswith(CPU_MS_SUFFIX)]
            missing = [c for c in columns if c not in present]
            if missing:
                raise FleetError(
                    f"{run.folder}: {path.name} of tool version {run.tool_version or 'unknown'} "
                    f"lacks {', '.join(missing)}: incompatible with this slt"
                )
            table = pq.read_table(path, columns=[c for c in wanted if c in present])
        except (OSError, pa.ArrowException) as err:
            raise FleetError(f"{run.folder}: cannot read {path.name}: {err}") from err
        frames[key] = table.to_pandas()
    return DriveTables(**frames)


def read_lanes(run: DriveRun) -> pd.DataFrame:
    """Read a drive's whole lanes table (every fitted line, for pre-annotations).

    Raises:
        FleetError: If it cannot be read.
    """
    path = RunLayout(run.folder).lanes
    try:
        lanes: pd.DataFrame = pq.read_table(path).to_pandas()
    except (OSError, pa.ArrowException) as err:
        raise FleetError(f"{run.folder}: cannot read {path.name}: {err}") from err
    return lanes
