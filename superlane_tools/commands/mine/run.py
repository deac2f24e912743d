"""``slt mine RUN_OR_ROOT... -o SET``: score frames, pick spread-out ones, export a label set.

The set (:mod:`superlane_tools.fleet.label_set`): the picked frames as JPEGs at their recorded
size with CULane pre-annotations beside them, ``labels.json`` (TuSimple lines) and
``manifest.parquet``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from superlane_tools.fleet.label_set import (
    LabelSet,
    export_label_set,
    mined_drives,
    scored_frames,
)
from superlane_tools.fleet.mined_spans import read_spans
from superlane_tools.fleet.mining import MineParams, select_frames
from superlane_tools.reporting import Provenance

MineResult = LabelSet
"""The picked frames (the manifest), what was skipped, and the files written."""


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
        FleetError: If an input is not a run, no drive is found, or ``compare_dir`` is not an
            ``slt compare`` output.
    """
    drives = mined_drives(inputs)
    pool, unscored = scored_frames(drives, read_spans(compare_dir), params, recordings)
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
    picks = select_frames(pool, params)
    exported = export_label_set(picks, drives, out, params, provenance, recordings)
    return MineResult(exported.manifest, (*unscored, *exported.skipped), exported.outputs)
