"""Every output table, declared once: a :class:`TableSpec` (name, file, schema, stage) each.

A new output table is one :func:`_table` line here (with its schema in :mod:`.schemas`): the
folder layouts (:mod:`.folders`) get an attribute of the table's name, the stage's table list
and schema map below include it, and :func:`.checks.checked_table` checks it. Readers take the
file name and columns from the spec (``LANES_TABLE.file``, ``CURVATURE_TABLE.pick(...)``).

Stages: ``streamed`` (written per frame during a reprocess pass), ``derived`` (written by
reprocess after the pass), ``extract`` (``slt extract``), ``summary`` (``slt batch``'s fleet
summary), ``batch`` (``slt batch``'s status), ``compare`` (``slt compare``), ``mine`` (``slt
mine``), ``history`` (``slt history``), ``corridor`` (``slt corridor``) and ``dataset``
(``slt simulate dataset``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import pyarrow as pa

from superlane_tools.reporting.layout import schemas as s
from superlane_tools.reporting.layout.schemas import DerivedSchema

Stage = Literal[
    "streamed",
    "derived",
    "extract",
    "summary",
    "batch",
    "compare",
    "mine",
    "history",
    "corridor",
    "dataset",
]


@dataclass(frozen=True)
class TableSpec:
    """One output table: its name, file, schema and the stage that writes it.

    Attributes:
        name: The table's name: its attribute in the stage's folder layout (``RunLayout.lanes``)
            and its key in the stage's table lists.
        file: The file name inside the output folder.
        schema: An exact Arrow schema (written with it), or a :class:`DerivedSchema` (checked).
        stage: What writes it (see the module docstring).
    """

    name: str
    file: str
    schema: pa.Schema | DerivedSchema
    stage: Stage

    def declared(self) -> DerivedSchema:
        """Return the schema as a :class:`DerivedSchema` (an exact schema: all required)."""
        if isinstance(self.schema, DerivedSchema):
            return self.schema
        return DerivedSchema(self.schema)

    @property
    def columns(self) -> tuple[str, ...]:
        """Every declared column, required then optional."""
        return tuple(self.declared().types())

    def pick(self, *columns: str) -> tuple[str, ...]:
        """Return ``columns`` after checking that each is a declared column of this table.

        Raises:
            KeyError: For a column the table does not declare (a reader out of date).
        """
        unknown = [c for c in columns if c not in self.declared().types()]
        if unknown:
            raise KeyError(f"{self.file} declares no column {unknown}")
        return columns


TABLES: list[TableSpec] = []
"""Every output table, in declaration order."""


def _table(stage: Stage, name: str, file: str, schema: pa.Schema | DerivedSchema) -> TableSpec:
    spec = TableSpec(name, file, schema, stage)
    if any(t.stage == stage and t.name == name for t in TABLES):
        raise ValueError(f"table {name!r} declared twice in stage {stage!r}")
    TABLES.append(spec)
    return spec


# ---- a reprocess run ----------------------------------------------------------------------
FRAMES_TABLE = _table("streamed", "frames", "frames.parquet", s.FRAMES_SCHEMA)
LANES_TABLE = _table("streamed", "lanes", "lanes.parquet", s.LANES_SCHEMA)
CORRIDOR_TABLE = _table("streamed", "corridor", "corridor.parquet", s.CORRIDOR_SCHEMA)
BASELINE_TABLE = _table("streamed", "baseline", "baseline.parquet", s.BASELINE_SCHEMA)
CAN_SIGNALS_TABLE = _table(
    "derived", "can_signals", "can_signals.parquet", DerivedSchema(s.CAN_SIGNALS_SCHEMA)
)
MOBILEYE_TABLE = _table("derived", "mobileye", "mobileye.parquet", s.MOBILEYE_SCHEMA)
RTK_TRUTH_TABLE = _table("derived", "rtk", "rtk.parquet", s.RTK_TRUTH_SCHEMA)
CURVATURE_TABLE = _table("derived", "curvature", "curvature.parquet", s.CURVATURE_SCHEMA)
CURVATURE_SUMMARY_TABLE = _table(
    "derived", "curvature_summary", "curvature_summary.parquet", s.CURVATURE_SUMMARY_SCHEMA
)
AVAILABILITY_FRAMES_TABLE = _table(
    "derived", "availability_frames", "availability_frames.parquet", s.AVAILABILITY_FRAMES_SCHEMA
)
AVAILABILITY_SEQUENCES_TABLE = _table(
    "derived",
    "availability_sequences",
    "availability_sequences.parquet",
    s.AVAILABILITY_SEQUENCES_SCHEMA,
)

# ---- slt extract (frames, CAN signals and RTK fixes share a reprocess run's file names) --------
EXTRACT_FRAMES_TABLE = _table("extract", "frames", FRAMES_TABLE.file, s.EXTRACT_FRAMES_SCHEMA)
CAMERA_INFO_TABLE = _table("extract", "camera_info", "camera_info.parquet", s.CAMERA_INFO_SCHEMA)
CAN_RAW_TABLE = _table("extract", "can_raw", "can_raw.parquet", s.CAN_RAW_SCHEMA)
EXTRACT_CAN_SIGNALS_TABLE = _table(
    "extract", "can_signals", CAN_SIGNALS_TABLE.file, s.CAN_SIGNALS_SCHEMA
)
RTK_TABLE = _table("extract", "rtk", RTK_TRUTH_TABLE.file, s.RTK_SCHEMA)

# ---- slt batch: the status at the output root, the fleet summary under ROOT/summary --------
BATCH_STATUS_TABLE = _table("batch", "batch_status", "batch_status.parquet", s.BATCH_STATUS_SCHEMA)
FLEET_STATUS_TABLE = _table(
    "summary", "fleet_status", "fleet_status.parquet", s.FLEET_STATUS_SCHEMA
)
AVAILABILITY_BY_CATEGORY_TABLE = _table(
    "summary",
    "availability_by_category",
    "availability_by_category.parquet",
    s.AVAILABILITY_BY_CATEGORY_SCHEMA,
)
CURVATURE_BY_RECORDING_TABLE = _table(
    "summary",
    "curvature_by_recording",
    "curvature_by_recording.parquet",
    s.CURVATURE_BY_RECORDING_SCHEMA,
)

# ---- slt compare, mine, history, corridor and simulate dataset -------------------------------
COMPARE_TABLE = _table("compare", "compare", "compare.parquet", s.COMPARE_SCHEMA)
COMPARE_SPANS_TABLE = _table("compare", "spans", "compare_spans.parquet", s.COMPARE_SPANS_SCHEMA)
COMPARE_DRIVES_TABLE = _table(
    "compare", "drives", "compare_drives.parquet", s.COMPARE_DRIVES_SCHEMA
)
MINE_MANIFEST_TABLE = _table("mine", "manifest", "manifest.parquet", s.MINE_MANIFEST_SCHEMA)
HISTORY_DRIFTS_TABLE = _table(
    "history", "drifts", "history_drifts.parquet", s.HISTORY_DRIFTS_SCHEMA
)
CORRIDOR_MASKS_TABLE = _table("corridor", "corridor", CORRIDOR_TABLE.file, s.CORRIDOR_MASKS_SCHEMA)
DATASET_INDEX_TABLE = _table("dataset", "index", "index.parquet", s.DATASET_INDEX_SCHEMA)


def tables_of(stage: Stage) -> dict[str, TableSpec]:
    """Return name -> spec of a stage's tables, in declaration order."""
    return {t.name: t for t in TABLES if t.stage == stage}


STREAMED_TABLES = tuple(tables_of("streamed"))
"""Tables written while the frames stream, one row per camera frame."""
DERIVED_TABLES = tuple(tables_of("derived"))
"""Tables derived after the pass (the fields of ``drive.DriveTables`` of the same names)."""
STREAMED_SCHEMAS: Mapping[str, pa.Schema] = {
    name: spec.schema
    for name, spec in tables_of("streamed").items()
    if isinstance(spec.schema, pa.Schema)
}
"""Schema of each table in :data:`STREAMED_TABLES`."""
DERIVED_SCHEMAS: Mapping[str, DerivedSchema] = {
    name: spec.declared() for name, spec in tables_of("derived").items()
}
"""Schema of each table in :data:`DERIVED_TABLES`."""
