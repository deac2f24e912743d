"""The fleet's history: every night's fleet KPIs and comparison, one partitioned Parquet dataset.

Layout (:class:`~superlane_tools.reporting.layout.HistoryLayout`): ``ROOT/history/`` is a
hive-partitioned dataset, one folder per night (``night=2026-12-03/``), each holding one file
per append (``fleet-<ns>.parquet``, ``compare-<ns>.parquet``; schema
:data:`~superlane_tools.reporting.layout.HISTORY_SCHEMA`). An append writes one new file
atomically (a temporary ``.name.tmp`` beside it, renamed) and never touches the files already
there, so a reader sees a night completely or not at all, and a crashed night leaves the
history as it was. A night appended twice (a rerun) keeps both files; :func:`read_history`
keeps the latest append of each night and kind.

Rows: ``fleet`` rows hold the night's fleet value of every KPI (pooled over every drive's
sequences, as ``slt compare`` pools them) with the number of drives and sequences that carry
it; ``compare`` rows copy the fleet rows of the night's ``compare.parquet`` (candidate value,
base value, delta, interval, verdict, and ``n_drives`` where the table has it). Each row names
the fleet's model (segmentation backends and model files), a short id of the model files'
SHA-256s and of the configuration (``output`` and ``workers`` left out: they change no
result), and the tool version, so model and configuration changes can be marked.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.dataset as ds

from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.kpis import KPI_BY_NAME, sequence_kpis
from superlane_tools.fleet.runs import DriveRun, find_drives, read_tables
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import (
    COMPARE_TABLE,
    HISTORY_PARTITION,
    HISTORY_SCHEMA,
    HistoryLayout,
)

KINDS = ("fleet", "compare")
NIGHT = re.compile(r"^\d{4}-\d{2}-\d{2}$")
"""A night's name: its date, ``YYYY-MM-DD``."""
RESULT_FREE_CONFIG = ("output", "workers", "resolved")
"""Configuration sections left out of the config id (outputs, parallelism, per-drive facts)."""


@dataclass(frozen=True)
class FleetIdentity:
    """What a fleet's runs were made with.

    Attributes:
        model: The segmentation backends and model files (``onnx:ego_corridor_v3; oracle``).
        model_id: First 12 hex digits of a SHA-256 over the model files' SHA-256s.
        config_id: First 12 hex digits of a SHA-256 over the configuration.
        tool_version: The tool versions of the runs (``; ``-joined when they differ).
    """

    model: str
    model_id: str
    config_id: str
    tool_version: str


def _short_hash(value: object) -> str:
    text = json.dumps(value, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def fleet_identity(drives: Iterable[DriveRun]) -> FleetIdentity:
    """Return the model, model id, config id and tool version of a fleet's runs."""
    models: dict[str, str] = {}
    backends, configs, versions = set(), set(), set()
    for drive in drives:
        prov = drive.provenance
        models.update({str(k): str(v) for k, v in (prov.get("models") or {}).items()})
        config = dict(prov.get("config") or {})
        backend = (config.get("resolved") or {}).get("segmentation_backend")
        if backend:
            backends.add(str(backend))
        configs.add(
            json.dumps(
                {k: v for k, v in config.items() if k not in RESULT_FREE_CONFIG},
                sort_keys=True,
                default=str,
            )
        )
        versions.add(drive.tool_version)
    names = sorted(backends | set(models))
    return FleetIdentity(
        model="; ".join(names),
        model_id=_short_hash([sorted(backends), sorted(models.items())]),
        config_id=_short_hash(sorted(configs)),
        tool_version="; ".join(sorted(v for v in versions if v)),
    )


def fleet_values(drives: Iterable[DriveRun]) -> pd.DataFrame:
    """Return the fleet value of every KPI: ``kpi``, ``value``, ``n_drives``, ``n_sequences``.

    The value pools every drive's sequence sums (``transform(sum num / sum den)``, as ``slt
    compare`` pools a fleet); a KPI no sequence carries is NaN with 0 drives.

    Raises:
        FleetError: If a drive's tables cannot be read.
    """
    parts = [sequence_kpis(read_tables(d)).assign(drive=d.key) for d in drives]
    if not parts:
        raise FleetError("empty fleet: no drive with a reprocess run")
    seqs = pd.concat(parts, ignore_index=True)
    carried = seqs[seqs["den"] > 0]
    sums = seqs.groupby("kpi", sort=False)[["num", "den"]].sum()
    rows = []
    for name, (num, den) in sums.iterrows():
        kpi = KPI_BY_NAME[str(name)]
        mine = carried[carried["kpi"] == name]
        value = kpi.pooled(np.array([num]), np.array([den]))[0]
        rows.append((kpi.name, float(value), mine["drive"].nunique(), len(mine)))
    return pd.DataFrame(rows, columns=["kpi", "value", "n_drives", "n_sequences"])


def _base_rows(night_kind: str, root: Path, baseline: str, fleet: FleetIdentity) -> dict[str, Any]:
    return {
        "recorded_ns": time.time_ns(),
        "kind": night_kind,
        "root": str(root),
        "baseline": baseline,
        "model": fleet.model,
        "model_id": fleet.model_id,
        "config_id": fleet.config_id,
        "tool_version": fleet.tool_version,
    }


def summary_rows(root: Path, values: pd.DataFrame, fleet: FleetIdentity) -> pd.DataFrame:
    """Return the ``fleet`` history rows of a night from :func:`fleet_values`."""
    kpis = [KPI_BY_NAME[k] for k in values["kpi"]]
    return pd.DataFrame(
        {
            **_base_rows("fleet", root, "", fleet),
            "kpi": values["kpi"].astype(str),
            "unit": [k.unit for k in kpis],
            "higher_is_better": [k.higher_is_better for k in kpis],
            "value": values["value"].astype(float),
            "n_drives": values["n_drives"].astype("Int64"),
            "n_sequences": values["n_sequences"].astype("Int64"),
        }
    )


def read_comparison(compare_dir: Path) -> pd.DataFrame:
    """Return the fleet rows of an ``slt compare`` output's table.

    Raises:
        FleetError: If the folder has no readable ``compare.parquet``.
    """
    path = compare_dir / COMPARE_TABLE.file
    try:
        table = pd.read_parquet(path)
    except (OSError, pa.ArrowException, ValueError) as err:
        raise FleetError(f"{compare_dir}: no readable {COMPARE_TABLE.file} ({err})") from err
    if "scope" not in table or "kpi" not in table:
        raise FleetError(f"{path}: not an slt compare table (no scope / kpi columns)")
    return table[table["scope"] == "fleet"].reset_index(drop=True)


def comparison_rows(
    root: Path,
    fleet_rows: pd.DataFrame,
    fleet: FleetIdentity,
    baseline: Path,
    base: FleetIdentity,
) -> pd.DataFrame:
    """Return the ``compare`` history rows of a night from its comparison's fleet rows.

    Columns the table lacks (``n_drives`` before the drive became the unit) are null.
    """

    def column(name: str, dtype: Any) -> pd.Series:
        if name in fleet_rows:
            out: pd.Series = fleet_rows[name].astype(dtype)
            return out
        return pd.Series([None] * len(fleet_rows), dtype=dtype)

    return pd.DataFrame(
        {
            **_base_rows("compare", root, str(baseline), fleet),
            "base_model": base.model,
            "base_config_id": base.config_id,
            "kpi": fleet_rows["kpi"].astype(str),
            "unit": column("unit", "string"),
            "higher_is_better": column("higher_is_better", "boolean"),
            "value": column("candidate", "float64"),
            "base_value": column("base", "float64"),
            "delta": column("delta", "float64"),
            "ci_low": column("ci_low", "float64"),
            "ci_high": column("ci_high", "float64"),
            "n_drives": column("n_drives", "Int64"),
            "n_sequences": column("n_sequences", "Int64"),
            "verdict": column("verdict", "string"),
        }
    )


def _as_table(rows: pd.DataFrame) -> pa.Table:
    columns = {}
    for field in HISTORY_SCHEMA:
        values = rows[field.name] if field.name in rows else pd.Series([None] * len(rows))
        values = values.astype(object).where(values.notna(), None)
        columns[field.name] = pa.array(values.tolist(), type=field.type)
    return pa.Table.from_pydict(columns, schema=HISTORY_SCHEMA)


def check_night(night: str) -> str:
    """Return ``night`` if it is a ``YYYY-MM-DD`` date.

    Raises:
        FleetError: Otherwise.
    """
    if not NIGHT.match(night):
        raise FleetError(f"night {night!r} is not a date YYYY-MM-DD")
    return night


def append_rows(history_root: Path, night: str, rows: pd.DataFrame, command: str = "") -> Path:
    """Append one night's rows (one kind) as a new file of the dataset; never rewrite a file.

    Raises:
        FleetError: If the rows are of no known kind, the night is no date, or the file that
            would be written exists (two appends in one nanosecond).
    """
    kinds = set(rows["kind"])
    if len(kinds) != 1 or not kinds <= set(KINDS):
        raise FleetError(f"history rows must be of one kind of {KINDS}, got {sorted(kinds)}")
    part = HistoryLayout(history_root).partition(check_night(night))
    path = part / f"{kinds.pop()}-{int(rows['recorded_ns'].iloc[0])}.parquet"
    if path.exists():
        raise FleetError(f"{path} exists: history files are never rewritten")
    provenance = Provenance(command=command or "history append", config={"night": night})
    return write_table(_as_table(rows), path, provenance)


def record_night(
    history_root: Path,
    night: str,
    root: Path,
    compare_dir: Path | None = None,
    baseline: Path | None = None,
    command: str = "",
) -> list[Path]:
    """Append a night's fleet summary (and its comparison, with ``compare_dir``) to the history.

    Args:
        history_root: The nightly root the dataset lives under (``history_root/history``).
        night: The night, ``YYYY-MM-DD``.
        root: The night's fleet (a batch root, a folder of runs or a run).
        compare_dir: The night's ``slt compare`` output (its fleet rows are appended).
        baseline: The comparison's base fleet (for its model and configuration).
        command: The command line recorded in the comparison file's provenance.

    Raises:
        FleetError: If a fleet or the comparison cannot be read.
    """
    check_night(night)
    drives = find_drives(root).drives
    fleet = fleet_identity(drives)
    written = [append_rows(history_root, night, summary_rows(root, fleet_values(drives), fleet))]
    if compare_dir is not None:
        unknown = FleetIdentity("", "", "", "")
        base = fleet_identity(find_drives(baseline).drives) if baseline is not None else unknown
        rows = comparison_rows(root, read_comparison(compare_dir), fleet, baseline or Path(), base)
        written.append(append_rows(history_root, night, rows, command))
    return written


def history_dataset(path: Path) -> Path:
    """Return the dataset folder of a history root (or of the dataset folder itself).

    Raises:
        FleetError: If ``path`` holds no ``night=DATE`` partition.
    """
    for folder in (HistoryLayout(path).dataset, path):
        if folder.is_dir() and any(folder.glob(f"{HISTORY_PARTITION}=*/*.parquet")):
            return folder
    raise FleetError(
        f"{path}: not a history root (no {HistoryLayout(path).dataset.name}/"
        f"{HISTORY_PARTITION}=YYYY-MM-DD/*.parquet; pipelines/nightly.py writes one)"
    )


def read_history(path: Path, latest: bool = True) -> pd.DataFrame:
    """Read the history dataset under ``path``: every row with its ``night``, sorted by night.

    Args:
        path: A history root (or the dataset folder).
        latest: Keep only the latest append of each night and kind (a rerun night replaces
            its earlier rows in the answer; the files stay).

    Raises:
        FleetError: If ``path`` is not a history root or a file cannot be read.
    """
    folder = history_dataset(path)
    partitioning = ds.partitioning(pa.schema([(HISTORY_PARTITION, pa.string())]), flavor="hive")
    try:
        dataset = ds.dataset(folder, format="parquet", partitioning=partitioning)
        table = dataset.to_table().to_pandas()
    except (OSError, pa.ArrowException) as err:
        raise FleetError(f"{folder}: unreadable history ({err})") from err
    table[HISTORY_PARTITION] = table[HISTORY_PARTITION].astype(str)
    if latest and len(table):
        last = table.groupby([HISTORY_PARTITION, "kind"])["recorded_ns"].transform("max")
        table = table[table["recorded_ns"] == last]
    ordered: pd.DataFrame = table.sort_values([HISTORY_PARTITION, "kind", "kpi"], kind="stable")
    return ordered.reset_index(drop=True)


def nightly_series(history: pd.DataFrame) -> pd.DataFrame:
    """Return one row per night and KPI: the night's fleet value and its comparison.

    Columns: ``night``, ``kpi``, ``value`` (the fleet summary's, else the comparison's
    candidate value), ``model``, ``model_id``, ``config_id``, ``verdict`` (the comparison's,
    null without one), ``delta``, ``ci_low``, ``ci_high``, ``n_drives``, ``n_sequences``.
    """
    key = [HISTORY_PARTITION, "kpi"]
    fleet = history[history["kind"] == "fleet"].set_index(key)
    comp = history[history["kind"] == "compare"].set_index(key)
    index = fleet.index.union(comp.index)
    out = pd.DataFrame(index=index)
    for name in ("value", "model", "model_id", "config_id", "n_drives", "n_sequences"):
        out[name] = fleet[name].reindex(index).combine_first(comp[name].reindex(index))
    for name in ("verdict", "delta", "ci_low", "ci_high", "baseline"):
        out[name] = comp[name].reindex(index)
    return out.reset_index().sort_values(key, kind="stable").reset_index(drop=True)


def changes(series: pd.DataFrame, column: str) -> list[tuple[str, str, str]]:
    """Return ``(night, before, after)`` for every night whose ``column`` differs from the last."""
    firsts = series.dropna(subset=[column]).groupby(HISTORY_PARTITION)[column].first()
    per_night = {str(k): str(v) for k, v in firsts.items()}
    out = []
    previous: str | None = None
    for night in sorted(per_night):
        value = str(per_night[night])
        if previous is not None and value != previous:
            out.append((night, previous, value))
        previous = value
    return out
