"""Fleets of ten drives for the gate: copies of the shared oracle runs, each its own recording.

A copy's provenance gets another content hash, so ten copies of one run are ten drives that pair
up with ten copies of another run of the same drive (copy ``k`` with copy ``k``). Every copy of
one run changes the same way, so a candidate's change is the same on every drive (zero spread).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from superlane_tools.reporting.parquet import METADATA_KEY
from superlane_tools.reporting.run_folder import write_run_manifest

DRIVES = 10


def _rewrite(path: Path, edit: Callable[[pa.Table], pa.Table]) -> None:
    table = pq.read_table(path)
    meta = table.schema.metadata
    pq.write_table(edit(table).replace_schema_metadata(meta), path)


def copy_fleet(
    run: Path,
    dst: Path,
    n: int = DRIVES,
    tag: str = "copy",
    edit: Callable[[Path], None] | None = None,
) -> Path:
    """Copy ``run`` ``n`` times under ``dst`` as drives ``d00``.. with content hash ``tag<k>``."""
    for k in range(n):
        out = dst / f"d{k:02d}"
        shutil.copytree(run, out)
        path = out / "availability_sequences.parquet"
        table = pq.read_table(path)
        meta = json.loads(table.schema.metadata[METADATA_KEY])
        meta["inputs"][0]["content_hash"] = f"{tag}{k}"
        pq.write_table(
            table.replace_schema_metadata({METADATA_KEY: json.dumps(meta).encode()}), path
        )
        if edit is not None:
            edit(out)
        (out / "run_manifest.json").unlink()
        write_run_manifest(out)
    return dst


def no_path_curvature(run: Path) -> None:
    """Drop SUPER's tracked-path curvature from a run (the candidate estimated none)."""

    def edit(table: pa.Table) -> pa.Table:
        i = table.schema.get_field_index("super_path_curvature")
        nan = pa.array(np.full(len(table), np.nan))
        return table.set_column(i, "super_path_curvature", nan)

    _rewrite(run / "curvature.parquet", edit)


def shifted_sequences(run: Path) -> None:
    """Move every KPI sequence's start by 1 ns (as if another ``kpi.window_s`` cut them)."""

    def edit(table: pa.Table) -> pa.Table:
        i = table.schema.get_field_index("start_ns")
        moved = pa.compute.add(table.column("start_ns"), 1)
        return table.set_column(i, "start_ns", moved)

    _rewrite(run / "availability_sequences.parquet", edit)


@dataclass(frozen=True)
class CopyFleets:
    """Fleets of :data:`DRIVES` drives (folders of run folders)."""

    base: Path
    repeat: Path
    blind: Path
    lost: Path
    shifted: Path
    other: Path
    small: Path


@pytest.fixture(scope="session")
def copy_fleets(oracle_runs: Any, tmp_path_factory: pytest.TempPathFactory) -> CopyFleets:
    """The shared oracle runs as fleets of ten drives (see the module docstring)."""
    import pyarrow.compute  # noqa: F401  (pa.compute)

    root = tmp_path_factory.mktemp("copies")
    return CopyFleets(
        base=copy_fleet(oracle_runs.base, root / "base"),
        repeat=copy_fleet(oracle_runs.repeat, root / "repeat"),
        blind=copy_fleet(oracle_runs.blind, root / "blind"),
        lost=copy_fleet(oracle_runs.repeat, root / "lost", edit=no_path_curvature),
        shifted=copy_fleet(oracle_runs.repeat, root / "shifted", edit=shifted_sequences),
        other=copy_fleet(oracle_runs.repeat, root / "other", tag="other"),
        small=copy_fleet(oracle_runs.blind, root / "small", n=4),
    )
