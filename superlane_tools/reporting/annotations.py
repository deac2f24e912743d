"""Foxglove annotations MCAP: ``foxglove.ImageAnnotations`` plus per-frame lane parameters.

Written with ``mcap_protobuf``: topic ``/slt/annotations`` holds the fitted lanes (line strips
coloured by marking colour, ego lines thicker) and the Hough baseline (red) on the camera
topic's timestamps; ``/slt/lane_parameters`` holds a ``google.protobuf.Struct`` per frame.
Open it next to the drive in Foxglove (image panel on the camera topic, annotations enabled).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.reporting.atomic import atomic_path

ANNOTATIONS_TOPIC = "/slt/annotations"
PARAMETERS_TOPIC = "/slt/lane_parameters"
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
        self._writer._writer.add_metadata(  # the protobuf writer wraps a plain MCAP writer
            "slt_annotations", {"camera_topic": camera_topic}
        )
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
        from google.protobuf.struct_pb2 import Struct

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
        params = Struct()
        params.update(dict(parameters))
        self._writer.write_message(PARAMETERS_TOPIC, params, log_time=t_ns, publish_time=t_ns)
        self.messages += 2

    def close(self, ok: bool) -> Path | None:
        """Finish the file; return its path, or None when discarded."""
        self._writer.finish()  # type: ignore[no-untyped-call]
        self._handle.close()
        self._ctx.__exit__(None if ok else RuntimeError, None, None)
        return self.path if ok else None
