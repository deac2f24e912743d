"""Frame extraction: image files per topic and the ``frames.parquet`` index, streamed."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

from superlane_tools.recording.base import SkipLog, field_value
from superlane_tools.recording.images import (
    header_size,
    imdecode,
    raw_pixels,
    safe_topic,
    sniff_format,
)
from superlane_tools.recording.video import DECODED_MSGTYPE, decoded_image
from superlane_tools.records import Message
from superlane_tools.reporting import OutputError, ParquetStreamWriter
from superlane_tools.reporting.atomic import temp_prefix
from superlane_tools.reporting.layout import EXTRACT_FRAMES_SCHEMA
from superlane_tools.reporting.provenance import ProvenanceSource, resolve_provenance

RAW_TYPES = {"sensor_msgs/msg/Image", "foxglove.RawImage"}
_EXT = {"jpg": ("jpeg", ".jpg"), "png": ("png", ".png")}
FLUSH_ROWS = 4096
WRITE_THREADS = 2
"""Image files are written by a few threads: file creation and I/O release the GIL."""
MAX_PENDING_WRITES = 32
"""At most this many encoded frames wait in memory for their file write."""
_OPEN_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_CLOEXEC", 0)


class ImageFileSink:
    """Writes frames of image topics as files and indexes them; memory stays flat.

    Each topic's files are written into a hidden staging folder beside their final folder
    (``frames/.<topic>.*.tmp``) with plain unbuffered writes from a few threads, and the folder
    is renamed to ``frames/<topic>`` when the extraction succeeds: the image folder appears
    whole or not at all, like the Parquet files, without a rename per file. A previous
    extraction's folder of the same topic is replaced.

    Args:
        out_dir: Output folder.
        index_name: File name of the frame index (``frames.parquet`` for ``slt extract``).
        images_name: Folder of the image files (``<images_name>/<topic>/``).
        frame_format: ``jpg``, ``png`` or ``none`` (index only, no image files).
        every: Keep every Nth frame of each topic (N >= 1).
        provenance: Provenance for ``frames.parquet`` (or a function returning it, called when
            the index is first written).
        skips: Where corrupt or unsupported frames are counted.
    """

    def __init__(
        self,
        out_dir: Path,
        frame_format: str,
        every: int,
        provenance: ProvenanceSource,
        skips: SkipLog,
        *,
        index_name: str,
        images_name: str,
    ) -> None:
        self.out_dir = out_dir
        self.index_path = out_dir / index_name
        self.images_dir = out_dir / images_name
        self.frame_format = frame_format
        self.every = every
        self.skips = skips
        self.seen: dict[str, int] = {}
        self.kept = 0
        self.failed = 0
        self._rows: dict[str, list[Any]] = {name: [] for name in EXTRACT_FRAMES_SCHEMA.names}
        self._writer: ParquetStreamWriter | None = None
        self._provenance = provenance
        self._folders: dict[str, tuple[str, str]] = {}  # topic -> (relative folder, staging)
        self._pool: ThreadPoolExecutor | None = None
        self._pending: deque[Future[None]] = deque()

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
            encoding = str(field_value(msg.data, "format", "encoding") or "")
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
        wanted = _EXT.get(self.frame_format)
        if msg.msgtype == DECODED_MSGTYPE:  # video frame, decoded in order by recording.video
            pixels, encoding = decoded_image(msg), str(data.format)
            width, height = int(pixels.shape[1]), int(pixels.shape[0])
            if wanted is None:
                return width, height, encoding, ""
            payload = _encode(pixels, wanted[1])
        elif msg.msgtype in RAW_TYPES:
            width, height = int(data.width), int(data.height)
            encoding = str(data.encoding)
            if wanted is None:
                return width, height, encoding, ""
            pixels = raw_pixels(data.data, width, height, encoding, int(data.step))
            payload = _encode(pixels, wanted[1])
        else:
            payload = data.data if isinstance(data.data, bytes) else bytes(data.data)
            fmt = sniff_format(payload)
            encoding = fmt or str(field_value(data, "format") or "unknown")
            size = header_size(payload, fmt) if fmt else _decoded_size(payload)
            if size is None:
                raise ValueError(f"corrupt {fmt} payload (bad header or truncated)")
            width, height = size
            if wanted is None:
                return width, height, encoding, ""
            if fmt != wanted[0]:
                payload = _encode(_decode(payload), wanted[1])
        folder, staging = self._folder(msg.topic)
        name = f"{index:06d}{wanted[1]}"
        self._submit(f"{staging}/{name}", payload)
        return width, height, encoding, f"{folder}/{name}"

    def _folder(self, topic: str) -> tuple[str, str]:
        """Return the topic's folder relative to the output folder and its staging folder."""
        known = self._folders.get(topic)
        if known is None:
            name = safe_topic(topic, {f.split("/", 1)[1] for f, _ in self._folders.values()})
            parent = self.images_dir
            try:
                parent.mkdir(parents=True, exist_ok=True)
                staging = tempfile.mkdtemp(prefix=temp_prefix(name), suffix=".tmp", dir=parent)
                Path(staging).chmod(0o777 & ~_UMASK)  # mkdtemp makes 0700, like the files: umask
            except OSError as err:
                raise OutputError(f"cannot write frames under {parent}: {err.strerror}") from err
            known = (f"frames/{name}", staging)
            self._folders[topic] = known
        return known

    def _submit(self, path: str, payload: bytes) -> None:
        """Write a file in the background, keeping the number of pending writes bounded."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(WRITE_THREADS, thread_name_prefix="slt-frames")
        while len(self._pending) >= MAX_PENDING_WRITES:
            self._pending.popleft().result()  # re-raises OutputError from the thread
        self._pending.append(self._pool.submit(_write_file, path, payload))

    def _flush(self) -> None:
        if not self._rows["topic"]:
            return
        if self._writer is None:
            provenance = resolve_provenance(self._provenance)
            path = self.index_path
            self._writer = ParquetStreamWriter(path, EXTRACT_FRAMES_SCHEMA, provenance).__enter__()
        self._writer.write(self._rows)
        self._rows = {name: [] for name in EXTRACT_FRAMES_SCHEMA.names}

    def close(self, ok: bool) -> list[Path]:
        """Finish the outputs (discard them all when ``ok`` is False); return the files."""
        try:
            while self._pending:
                self._pending.popleft().result()
            if ok:
                self._flush()
                if self._writer is None:  # no frame kept: still write the (empty) index
                    provenance = resolve_provenance(self._provenance)
                    self._writer = ParquetStreamWriter(
                        self.index_path, EXTRACT_FRAMES_SCHEMA, provenance
                    ).__enter__()
        except BaseException:
            ok = False
            raise
        finally:
            if self._pool is not None:
                self._pool.shutdown(wait=True, cancel_futures=True)
            if self._writer is not None:
                self._writer.__exit__(None if ok else RuntimeError, None, None)
            self._finish_folders(ok)
        if not ok or self._writer is None:
            return []
        return [self._writer.path]

    def _finish_folders(self, ok: bool) -> None:
        """Rename each staging folder to its topic folder (``ok``) or remove it."""
        try:
            for rel, staging in self._folders.values():
                if ok:
                    _publish(Path(staging), self.out_dir / rel)
                else:
                    shutil.rmtree(staging, ignore_errors=True)
        finally:  # a failed publish must not leak the other staging folders
            for _, staging in self._folders.values():
                shutil.rmtree(staging, ignore_errors=True)


def _publish(staging: Path, final: Path) -> None:
    """Rename a finished staging folder to ``final``, replacing an earlier folder there.

    Raises:
        OutputError: If the rename fails (an earlier folder is then left in place).
    """
    old: Path | None = None
    try:
        if final.exists():
            old = Path(
                tempfile.mkdtemp(prefix=temp_prefix(final.name), suffix=".old", dir=final.parent)
            )
            final.replace(old / final.name)
        staging.replace(final)
    except OSError as err:
        if old is not None and (old / final.name).exists() and not final.exists():
            (old / final.name).replace(final)
        shutil.rmtree(staging, ignore_errors=True)
        raise OutputError(f"cannot write {final}: {err.strerror}") from err
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _umask()  # read once at import: changing it later races with the writer threads


def _write_file(path: str, payload: bytes) -> None:
    """Create ``path`` and write ``payload`` with unbuffered system calls (no Python buffer).

    Raises:
        OutputError: If the file cannot be written.
    """
    try:
        fd = os.open(path, _OPEN_FLAGS, 0o666)
        try:
            view = memoryview(payload)
            while view:
                view = view[os.write(fd, view) :]
        finally:
            os.close(fd)
    except OSError as err:
        raise OutputError(f"cannot write {path}: {err.strerror}") from err


def _decode(payload: bytes) -> Any:
    import cv2

    return imdecode(payload, cv2.IMREAD_UNCHANGED)


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
