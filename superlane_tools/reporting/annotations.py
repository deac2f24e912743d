"""Foxglove annotations MCAP: ``foxglove.ImageAnnotations`` plus per-frame lane parameters.

Written with ``mcap_protobuf``: topic ``/slt/annotations`` holds the fitted lanes (line strips
coloured by marking colour, ego lines thicker) and the Hough baseline (red) on the camera
topic's timestamps; ``/slt/lane_parameters`` holds one JSON message per frame with a JSON
schema (:data:`LANE_PARAMETERS_SCHEMA`: named numeric fields that Foxglove's plot panel lists,
e.g. ``/slt/lane_parameters.curvature_per_m``). :func:`add_signals` adds decoded CAN signals
and the truth curves as further JSON channels, so one file shows the drive in Foxglove.
Open it next to the drive in Foxglove (image panel on the camera topic, annotations enabled).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from superlane_tools.reporting.atomic import atomic_path

if TYPE_CHECKING:
    import pandas as pd

ANNOTATIONS_TOPIC = "/slt/annotations"
PARAMETERS_TOPIC = "/slt/lane_parameters"
SIGNALS_PREFIX = "/slt/signals/"
TRUTH_TOPIC = "/slt/truth"
_NUM = {"type": ["number", "null"]}
_INT = {"type": ["integer", "null"]}
LANE_PARAMETERS_SCHEMA: dict[str, Any] = {
    "title": "slt.LaneParameters",
    "description": "Per-frame lane fit of slt reprocess (vehicle frame: x forward, y left).",
    "type": "object",
    "properties": {
        "frame_index": {"type": "integer"},
        "a1_rad": {**_NUM, "description": "Heading of the lanes relative to the vehicle, rad"},
        "a2_per_m": {**_NUM, "description": "Half the curvature, 1/m"},
        "curvature_per_m": {**_NUM, "description": "Lane curvature, 1/m (left positive)"},
        "slope": {**_NUM, "description": "Road slope term b"},
        "ego_left": _INT,
        "ego_right": _INT,
        "lane_width_m": {**_NUM, "description": "Ego lane width, m"},
        "quality": {"type": "number"},
        "reason": {"type": "string"},
        "super_corridor_width_m": _NUM,
        "corridor_net_width_m": _NUM,
        "corridor_net_length_m": _NUM,
        "lanes": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "offset_m": {"type": "number"},
                    "a1_rad": {"type": "number"},
                    "a2_per_m": {"type": "number"},
                    "range_min_m": {"type": "number"},
                    "range_max_m": {"type": "number"},
                    "colour": {"type": "string"},
                    "style": {"type": "string"},
                },
            },
        },
    },
}
"""JSON schema of the ``/slt/lane_parameters`` messages."""
_RGBA = {
    "white": (1.0, 1.0, 1.0, 1.0),
    "yellow": (1.0, 0.84, 0.0, 1.0),
    "unknown": (0.0, 1.0, 1.0, 1.0),
    "hough": (1.0, 0.0, 0.0, 0.8),
}


class AnnotationWriter:
    """Streams annotation messages into an MCAP file, finalised atomically by :meth:`close`.

    Args:
        path: Target ``.mcap``.
        camera_topic: The camera topic annotated (recorded in the file's metadata).
    """

    def __init__(self, path: Path, camera_topic: str) -> None:
        from mcap_protobuf.writer import Writer

        self.path = path
        self._ctx = atomic_path(path, suffix=".mcap")
        tmp = self._ctx.__enter__()
        self._handle = tmp.open("wb")
        self._writer = Writer(self._handle)
        plain = self._writer._writer  # the protobuf writer wraps a plain MCAP writer
        plain.add_metadata("slt_annotations", {"camera_topic": camera_topic})
        self._params_channel = json_channel(plain, PARAMETERS_TOPIC, LANE_PARAMETERS_SCHEMA)
        self.messages = 0

    def add(
        self,
        t_ns: int,
        lanes: Sequence[tuple[NDArray[np.float64], str, str, bool]],
        hough_lines: Sequence[NDArray[np.float64]],
        parameters: Mapping[str, Any],
    ) -> None:
        """Write the annotations and the lane parameters of one frame.

        Args:
            t_ns: The image's log time (annotations carry it as their timestamp), ns.
            lanes: ``(uv pixels, colour, style, ego)`` per fitted lane, at the recorded size.
            hough_lines: ``(2, 2)`` pixel segments of the Hough baseline.
            parameters: JSON-able per-frame lane parameters.
        """
        from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
        from foxglove_schemas_protobuf.PointsAnnotation_pb2 import PointsAnnotation

        msg = ImageAnnotations()
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        items = [(uv, colour, 6.0 if ego else 3.0) for uv, colour, _, ego in lanes]
        items += [(seg, "hough", 2.0) for seg in hough_lines]
        for uv, colour, thickness in items:
            if len(uv) < 2:
                continue
            ann = msg.points.add()
            ann.timestamp.seconds, ann.timestamp.nanos = sec, nsec
            ann.type = PointsAnnotation.Type.LINE_STRIP
            r, g, b, a = _RGBA.get(colour, _RGBA["unknown"])
            ann.outline_color.r, ann.outline_color.g = r, g
            ann.outline_color.b, ann.outline_color.a = b, a
            ann.thickness = thickness
            for u, v in np.asarray(uv, dtype=np.float64):
                pt = ann.points.add()
                pt.x, pt.y = float(u), float(v)
        self._writer.write_message(ANNOTATIONS_TOPIC, msg, log_time=t_ns, publish_time=t_ns)
        self._writer._writer.add_message(self._params_channel, t_ns, _json_bytes(parameters), t_ns)
        self.messages += 2

    def close(self, ok: bool) -> Path | None:
        """Finish the file; return its path, or None when discarded."""
        self._writer.finish()  # type: ignore[no-untyped-call]
        self._handle.close()
        self._ctx.__exit__(None if ok else RuntimeError, None, None)
        return self.path if ok else None


def _json_bytes(data: Mapping[str, Any]) -> bytes:
    return json.dumps(_clean(data), separators=(",", ":"), allow_nan=False).encode()


def _clean(value: Any) -> Any:
    """Return JSON-ready data: numpy scalars as Python numbers, NaN and infinities as null."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_clean(v) for v in value]
    return value


def json_channel(writer: Any, topic: str, schema: Mapping[str, Any]) -> int:
    """Register a ``json`` channel with a ``jsonschema`` schema on a plain MCAP writer."""
    schema_id = writer.register_schema(
        name=str(schema.get("title", topic)),
        encoding="jsonschema",
        data=json.dumps(schema, sort_keys=True).encode(),
    )
    channel_id: int = writer.register_channel(
        topic=topic, message_encoding="json", schema_id=schema_id
    )
    return channel_id


def _finite(value: Any) -> float | None:
    v = float(value)
    return v if math.isfinite(v) else None


_Row = tuple[int, str, dict[str, Any]]
"""One JSON message to add: ``(log time ns, topic, values)``."""


def add_signals(
    annotations: Path, can_signals: pd.DataFrame | None, curvature: pd.DataFrame | None
) -> dict[str, int]:
    """Add decoded CAN signals and the truth curves to an ``annotations.mcap``, atomically.

    Each CAN message becomes a JSON channel ``/slt/signals/<message>`` with one numeric field per
    signal (named by the signal, unit in the schema's description); the curvature table's
    curves (RTK truth, SUPER, Mobileye, speed, yaw rate) become ``/slt/truth``.

    Args:
        annotations: The ``annotations.mcap`` written by reprocess.
        can_signals: The run's decoded CAN signals table (None or empty: no CAN channels).
        curvature: The run's curvature table (None: no truth channel).

    Returns:
        Messages written per added topic.
    """
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    from superlane_tools.recording.mcap_copy import McapCopier

    rows: list[_Row] = []
    schemas: dict[str, dict[str, Any]] = {}
    if can_signals is not None and len(can_signals):
        _signal_rows(can_signals, rows, schemas)
    if curvature is not None:
        _truth_rows(curvature, rows, schemas)
    rows.sort(key=lambda r: r[0])
    counts: dict[str, int] = {}
    with (
        atomic_path(annotations, suffix=".mcap") as tmp,
        annotations.open("rb") as fin,
        tmp.open("wb") as fout,
    ):
        reader = make_reader(fin)
        header = reader.get_header()
        writer = Writer(fout, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile, library=header.library)
        copier = McapCopier(writer)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            copier.add(schema, channel, message)
        fin.seek(0)
        for record in make_reader(fin).iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        added = {topic: json_channel(writer, topic, schema) for topic, schema in schemas.items()}
        for t_ns, topic, values in rows:
            writer.add_message(added[topic], t_ns, _json_bytes(values), t_ns)
            counts[topic] = counts.get(topic, 0) + 1
        writer.finish()  # type: ignore[no-untyped-call]
    return counts


def _signal_rows(table: pd.DataFrame, rows: list[_Row], schemas: dict[str, dict[str, Any]]) -> None:
    """Add one message per CAN message and time to ``rows``, and each message's schema."""
    for (message, t_ns), group in table.groupby(["message", "log_time_ns"], sort=False):
        topic = SIGNALS_PREFIX + str(message)
        values = {str(s): _finite(v) for s, v in zip(group["signal"], group["value"], strict=True)}
        rows.append((int(cast(Any, t_ns)), topic, values))
        if topic not in schemas:
            units = dict(
                zip(
                    table.loc[table["message"] == message, "signal"],
                    table.loc[table["message"] == message, "unit"],
                    strict=True,
                )
            )
            schemas[topic] = {
                "title": f"slt.can.{message}",
                "type": "object",
                "properties": {
                    str(sig): {**_NUM, "description": str(unit or "")}
                    for sig, unit in units.items()
                },
            }  # fmt: skip


def _truth_rows(curves: pd.DataFrame, rows: list[_Row], schemas: dict[str, dict[str, Any]]) -> None:
    """Add one truth message per row of the curvature table to ``rows``, and its schema."""
    wanted = [c for c in _TRUTH_COLUMNS if c in curves.columns]
    schemas[TRUTH_TOPIC] = {
        "title": "slt.Truth",
        "type": "object",
        "properties": {c: {**_NUM, "description": _TRUTH_COLUMNS[c]} for c in wanted},
    }
    rows.extend(
        (
            int(rec[0]),
            TRUTH_TOPIC,
            {c: _finite(v) for c, v in zip(wanted, rec[1:], strict=True)},
        )
        for rec in curves[["log_time_ns", *wanted]].itertuples(index=False)
    )


_TRUTH_COLUMNS = {
    "rtk_curvature": "RTK (GNSS track) curvature, 1/m",
    "super_curvature": "SUPER lane-fit curvature, 1/m",
    "super_path_curvature": "SUPER tracked path curvature, 1/m",
    "mobileye_curvature": "Mobileye lane curvature, 1/m",
    "speed_mps": "Vehicle speed, m/s",
    "yaw_rate_rps": "Yaw rate, rad/s",
    "super_error": "SUPER minus RTK curvature, 1/m",
}
