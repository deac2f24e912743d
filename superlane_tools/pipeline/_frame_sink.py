"""Frame extraction: image files per topic and the ``frames.parquet`` index, streamed."""

from __future__ import annotations

from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from superlane_tools.pipeline._images import header_size, raw_pixels, safe_topic, sniff_format
from superlane_tools.recording.base import SkipLog
from superlane_tools.records import Message
from superlane_tools.reporting import ParquetStreamWriter, Provenance, write_bytes_atomic

FRAMES_SCHEMA = pa.schema(
    [
        ("topic", pa.string()),
        ("index", pa.int64()),
        ("log_time_ns", pa.int64()),
        ("stamp_ns", pa.int64()),
        ("width", pa.int32()),
        ("height", pa.int32()),
        ("encoding", pa.string()),
        ("path", pa.string()),
        ("ok", pa.bool_()),
        ("error", pa.string()),
    ]
)
CAMERA_INFO_SCHEMA = pa.schema(
    [
        ("topic", pa.string()),
        ("log_time_ns", pa.int64()),
        ("frame_id", pa.string()),
        ("width", pa.int32()),
        ("height", pa.int32()),
        ("distortion_model", pa.string()),
        ("d", pa.list_(pa.float64())),
        ("k", pa.list_(pa.float64())),
        ("r", pa.list_(pa.float64())),
        ("p", pa.list_(pa.float64())),
    ]
)
RAW_TYPES = {"sensor_msgs/msg/Image", "foxglove.RawImage"}
_EXT = {"jpg": ("jpeg", ".jpg"), "png": ("png", ".png")}
FLUSH_ROWS = 4096
WRITE_THREADS = 4
"""Image files are written by a few threads: file creation and I/O release the GIL."""
MAX_PENDING_WRITES = 32
"""At most this many encoded frames wait in memory for their file write."""


def _field(data: Any, *names: str) -> Any:
    for name in names:
        value = getattr(data, name, None)
        if value is not None:
            return value
    return None


class FrameSink:
    """Writes frames of image topics as files and indexes them; memory stays flat.

    Args:
        out_dir: Output folder (files go to ``frames/<topic>/``).
        frame_format: ``jpg``, ``png`` or ``none`` (index only, no image files).
        every: Keep every Nth frame of each topic (N >= 1).
        provenance: Provenance for ``frames.parquet``.
        skips: Where corrupt or unsupported frames are counted.
    """

    def __init__(
        self,
        out_dir: Path,
        frame_format: str,
        every: int,
        provenance: Provenance,
        skips: SkipLog,
    ) -> None:
        self.out_dir = out_dir
        self.frame_format = frame_format
        self.every = every
        self.skips = skips
        self.seen: dict[str, int] = {}
        self.kept = 0
        self.failed = 0
        self._rows: dict[str, list[Any]] = {name: [] for name in FRAMES_SCHEMA.names}
        self._writer = ParquetStreamWriter(out_dir / "frames.parquet", FRAMES_SCHEMA, provenance)
        self._writer.__enter__()
        self._info_rows: list[dict[str, Any]] = []
        self._last_info: dict[str, tuple[Any, ...]] = {}
        self._provenance = provenance
        self._pool = ThreadPoolExecutor(WRITE_THREADS, thread_name_prefix="slt-frames")
        self._pending: deque[Future[Path]] = deque()

    def add(self, msg: Message) -> None:
        """Index (and write) one image message, honouring ``every``."""
        index = self.seen.get(msg.topic, 0)
        self.seen[msg.topic] = index + 1
        if index % self.every:
            return
        try:
            width, height, encoding, rel_path = self._write(msg, index)
            ok, error = True, ""
        except ValueError as err:
            width = height = 0
            encoding = str(_field(msg.data, "format", "encoding") or "")
            rel_path, ok, error = "", False, str(err)
            self.failed += 1
            self.skips.add("corrupt image", f"{msg.topic}: {err}")
        self.kept += 1
        row = self._rows
        row["topic"].append(msg.topic)
        row["index"].append(index)
        row["log_time_ns"].append(msg.log_time_ns)
        row["stamp_ns"].append(msg.stamp_ns)
        row["width"].append(width)
        row["height"].append(height)
        row["encoding"].append(encoding)
        row["path"].append(rel_path)
        row["ok"].append(ok)
        row["error"].append(error)
        if len(row["topic"]) >= FLUSH_ROWS:
            self._flush()

    def _write(self, msg: Message, index: int) -> tuple[int, int, str, str]:
        """Write one frame's file; return width, height, encoding and relative path."""
        data = msg.data
        folder = Path("frames") / safe_topic(msg.topic)
        wanted = _EXT.get(self.frame_format)
        if msg.msgtype in RAW_TYPES:
            width, height = int(data.width), int(data.height)
            encoding = str(data.encoding)
            if wanted is None:
                return width, height, encoding, ""
            pixels = raw_pixels(data.data, width, height, encoding, int(data.step))
            payload = _encode(pixels, wanted[1])
        else:
            payload = bytes(data.data)
            fmt = sniff_format(payload)
            encoding = fmt or str(_field(data, "format") or "unknown")
            size = header_size(payload, fmt) if fmt else _decoded_size(payload)
            if size is None:
                raise ValueError(f"corrupt {fmt} payload (bad header or truncated)")
            width, height = size
            if wanted is None:
                return width, height, encoding, ""
            if fmt != wanted[0]:
                payload = _encode(_decode(payload), wanted[1])
        rel_path = folder / f"{index:06d}{wanted[1]}"
        self._submit(self.out_dir / rel_path, payload)
        return width, height, encoding, rel_path.as_posix()

    def _submit(self, path: Path, payload: bytes) -> None:
        """Write a file in the background, keeping the number of pending writes bounded."""
        while len(self._pending) >= MAX_PENDING_WRITES:
            self._pending.popleft().result()  # re-raises OutputError from the thread
        self._pending.append(self._pool.submit(write_bytes_atomic, path, payload))

    def add_camera_info(self, msg: Message) -> None:
        """Keep a camera calibration (one row per topic whenever it changes)."""
        data = msg.data
        d, k = _floats(_field(data, "d", "D")), _floats(_field(data, "k", "K"))
        r, p = _floats(_field(data, "r", "R")), _floats(_field(data, "p", "P"))
        width, height = int(_field(data, "width") or 0), int(_field(data, "height") or 0)
        model = str(_field(data, "distortion_model") or "")
        key = (width, height, model, tuple(d), tuple(k), tuple(r), tuple(p))
        if self._last_info.get(msg.topic) == key:
            return
        self._last_info[msg.topic] = key
        header = _field(data, "header")
        frame_id = str(_field(header, "frame_id") or _field(data, "frame_id") or "")
        self._info_rows.append(
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

    def _flush(self) -> None:
        if self._rows["topic"]:
            self._writer.write(self._rows)
            self._rows = {name: [] for name in FRAMES_SCHEMA.names}

    def close(self, ok: bool) -> list[Path]:
        """Finish the outputs (discard ``frames.parquet`` when ``ok`` is False); return them."""
        from superlane_tools.reporting import write_table

        written = []
        try:
            while self._pending:
                self._pending.popleft().result()
        except BaseException:
            ok = False
            raise
        finally:
            self._pool.shutdown(wait=True, cancel_futures=True)
            if ok:
                self._flush()
            self._writer.__exit__(None if ok else RuntimeError, None, None)
        if ok:
            written.append(self._writer.path)
            if self._info_rows:
                table = pa.Table.from_pylist(self._info_rows, schema=CAMERA_INFO_SCHEMA)
                written.append(
                    write_table(table, self.out_dir / "camera_info.parquet", self._provenance)
                )
        return written


def _floats(value: Any) -> list[float]:
    return [] if value is None else [float(v) for v in value]


def _decode(payload: bytes) -> Any:
    import cv2

    pixels = cv2.imdecode(np.frombuffer(payload, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise ValueError("image payload cannot be decoded")
    return pixels


def _decoded_size(payload: bytes) -> tuple[int, int]:
    """Size of an image in a format without a header reader (decoded by cv2)."""
    if not payload:
        raise ValueError("empty image payload")
    pixels = _decode(payload)
    return int(pixels.shape[1]), int(pixels.shape[0])


def _encode(pixels: Any, ext: str) -> bytes:
    import cv2

    ok, buffer = cv2.imencode(ext, pixels)
    if not ok:
        raise ValueError(f"cv2 cannot encode this image as {ext}")
    return bytes(buffer)
