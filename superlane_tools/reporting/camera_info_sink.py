"""Camera calibration extraction: ``camera_info.parquet``, one row per topic and change."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pyarrow as pa

from superlane_tools.recording.base import field_value
from superlane_tools.records import Message
from superlane_tools.reporting import write_table
from superlane_tools.reporting.layout import CAMERA_INFO_SCHEMA
from superlane_tools.reporting.provenance import ProvenanceSource, resolve_provenance


class CameraInfoSink:
    """Keeps each camera calibration (CameraInfo) once per topic and change; writes the table.

    Args:
        path: The calibration table.
        provenance: Provenance for the Parquet file (or a function returning it, called at
            :meth:`close`).
    """

    def __init__(self, path: Path, provenance: ProvenanceSource) -> None:
        self.path = path
        self._provenance = provenance
        self._rows: list[dict[str, Any]] = []
        self._last: dict[str, tuple[Any, ...]] = {}

    def add(self, msg: Message) -> None:
        """Keep a camera calibration (one row per topic whenever it changes)."""
        data = msg.data
        d, k = _floats(field_value(data, "d", "D")), _floats(field_value(data, "k", "K"))
        r, p = _floats(field_value(data, "r", "R")), _floats(field_value(data, "p", "P"))
        width, height = int(field_value(data, "width") or 0), int(field_value(data, "height") or 0)
        model = str(field_value(data, "distortion_model") or "")
        key = (width, height, model, tuple(d), tuple(k), tuple(r), tuple(p))
        if self._last.get(msg.topic) == key:
            return
        self._last[msg.topic] = key
        header = field_value(data, "header")
        frame_id = str(field_value(header, "frame_id") or field_value(data, "frame_id") or "")
        self._rows.append(
            {
                "topic": msg.topic,
                "log_time_ns": msg.log_time_ns,
                "frame_id": frame_id,
                "width": width,
                "height": height,
                "distortion_model": model,
                "d": d,
                "k": k,
                "r": r,
                "p": p,
            }
        )

    def close(self, ok: bool) -> list[Path]:
        """Write the table (``ok`` and some calibration kept); return the files written."""
        if not ok or not self._rows:
            return []
        table = pa.Table.from_pylist(self._rows, schema=CAMERA_INFO_SCHEMA)
        return [write_table(table, self.path, resolve_provenance(self._provenance))]


def _floats(value: Any) -> list[float]:
    return [] if value is None else [float(v) for v in value]
