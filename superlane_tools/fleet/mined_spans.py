"""The disagreement spans of ``slt compare`` that belong to a mined drive, joined by content hash.

A span belongs to a drive when both come from the same recording content (the blake3 hash in
the runs' provenance), wherever the recording was stored or however it was named: the same
drive moved to another disk, or two copies under other names, still get their spans. A span
row names its runs through their ``annotations.mcap`` paths; the hash is read from that run
folder's provenance (a ``content_hash`` column, when the comparison has one, is used as is).
Only when no hash is known on either side are spans matched by recording path.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pandas as pd

from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.runs import DriveRun, find_drives
from superlane_tools.reporting.layout import COMPARE_SPANS_TABLE, CompareLayout

NO_HASH = "folder:"
"""Prefix of a drive key made from its folder name (no content hash in its provenance)."""
SPAN_COLUMNS = list(COMPARE_SPANS_TABLE.pick("recording", "content_hash", "start_ns", "stop_ns"))


def drive_hash(drive: DriveRun) -> str:
    """Return the drive's recording content hash ("" when its provenance has none)."""
    content = drive.key.partition("|")[0]
    return "" if content.startswith(NO_HASH) else content


@cache
def _run_hash(annotations: str) -> str:
    """Return the content hash of the run folder holding ``annotations`` ("" if unknown)."""
    folder = Path(annotations).parent
    try:
        drives = find_drives(folder).drives
    except FleetError:
        return ""
    return drive_hash(drives[0]) if len(drives) == 1 else ""


def read_spans(compare_dir: Path | None) -> pd.DataFrame:
    """Return the spans of an ``slt compare`` output with each one's recording content hash.

    Raises:
        FleetError: If ``compare_dir`` is not an ``slt compare`` output.
    """
    if compare_dir is None:
        return pd.DataFrame(columns=SPAN_COLUMNS)
    path = CompareLayout(compare_dir).spans
    if not path.is_file():
        raise FleetError(f"{compare_dir}: no {path.name} (not an slt compare output)")
    spans = pd.read_parquet(path)
    if spans.empty:
        return pd.DataFrame(columns=SPAN_COLUMNS)
    if "content_hash" not in spans:
        hashes = []
        for row in spans.itertuples(index=False):
            runs = (getattr(row, "base_annotations", ""), getattr(row, "candidate_annotations", ""))
            found = [_run_hash(str(p)) for p in runs if p]
            hashes.append(next((h for h in found if h), ""))
        spans = spans.assign(content_hash=hashes)
    return spans


def drive_ranges(spans: pd.DataFrame, drive: DriveRun) -> list[tuple[int, int]]:
    """Return the ``[start_ns, stop_ns)`` spans of ``drive``: same content hash, else same path.

    The path decides only where a hash is missing (on the span's or the drive's side).
    """
    content = drive_hash(drive)
    known = spans["content_hash"].fillna("").astype(str)
    by_path = spans["recording"].astype(str) == drive.recording
    mine = spans[(known == content) | ((known == "") & by_path)] if content else spans[by_path]
    return list(zip(mine["start_ns"].astype(int), mine["stop_ns"].astype(int), strict=True))
