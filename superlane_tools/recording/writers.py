"""Write recordings: MCAP (ROS 2 CDR or ROS 1), ROS 1 bags and ROS 2 bags, deterministically."""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Iterable, Mapping
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Literal, Protocol, Self, get_args

from superlane_tools.recording.base import ros2_msgtype
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.typestore import default_typestore, ros1_typestore

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

WriterFormat = Literal["mcap", "mcap-ros1", "ros1", "ros2"]
Ros2Storage = Literal["sqlite3", "mcap"]
McapCompression = Literal["zstd", "lz4", "none"]

LIBRARY = "superlane-tools"
"""Library string written into MCAP headers; a constant so output bytes never depend on versions."""

MCAP_CHUNK_SIZE = 1024 * 1024
"""Uncompressed MCAP chunk size, bytes."""


def _ros1_store_for(msgtype: str, store: Typestore) -> Typestore:
    """Return the store whose ROS 1 definition of ``msgtype`` matches the ROS 1 payloads.

    ROS 2 definitions lack ``Header.seq``; the ROS 1 payloads written here carry it (see
    :func:`_serialize`), so definitions and MD5 sums come from the ROS 1 store when it knows the
    type, else from ``store`` (a custom type registered only there).
    """
    ros1 = ros1_typestore()
    return ros1 if msgtype in ros1.fielddefs else store


def _serialize(store: Typestore, message: object, msgtype: str, ros1: bool) -> bytes:
    """Serialize a ROS 2 typestore instance to CDR, or to ROS 1 bytes (``Header.seq`` = 0)."""
    cdr = store.serialize_cdr(message, msgtype)
    if not ros1:
        return bytes(cdr)
    return bytes(store.cdr_to_ros1(cdr, msgtype))


class _Backend(Protocol):
    def add_topic(self, topic: str, msgtype: str) -> None: ...
    def write(self, topic: str, log_time_ns: int, message: object) -> None: ...
    def close(self) -> None: ...


class _McapBackend:
    """MCAP with ``ros2msg`` schemas and CDR payloads, or ``ros1msg`` schemas and ROS 1 payloads."""

    def __init__(
        self,
        path: Path,
        ros1: bool,
        store: Typestore,
        chunk_size: int,
        compression: McapCompression,
    ) -> None:
        from mcap.writer import CompressionType
        from mcap.writer import Writer as McapWriter

        self._store = store
        self._ros1 = ros1
        self._file = path.open("wb")
        self._writer = McapWriter(
            self._file, chunk_size=chunk_size, compression=CompressionType[compression.upper()]
        )
        self._writer.start(profile="ros1" if ros1 else "ros2", library=LIBRARY)
        self._channels: dict[str, tuple[int, str]] = {}
        self._sequence: dict[str, int] = {}

    def add_topic(self, topic: str, msgtype: str) -> None:
        if self._ros1:
            msgdef, _ = _ros1_store_for(msgtype, self._store).generate_msgdef(msgtype)
        else:
            msgdef, _ = self._store.generate_msgdef(msgtype, ros_version=2)
        name = msgtype.replace("/msg/", "/") if self._ros1 else msgtype
        schema_id = self._writer.register_schema(
            name=name,
            encoding="ros1msg" if self._ros1 else "ros2msg",
            data=msgdef.encode("utf-8"),
        )
        channel_id = self._writer.register_channel(
            topic=topic, message_encoding="ros1" if self._ros1 else "cdr", schema_id=schema_id
        )
        self._channels[topic] = (channel_id, msgtype)
        self._sequence[topic] = 0

    def write(self, topic: str, log_time_ns: int, message: object) -> None:
        channel_id, msgtype = self._channels[topic]
        data = _serialize(self._store, message, msgtype, self._ros1)
        self._sequence[topic] += 1
        self._writer.add_message(
            channel_id=channel_id,
            log_time=log_time_ns,
            data=bytes(data),
            publish_time=log_time_ns,
            sequence=self._sequence[topic],
        )

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        self._writer.add_metadata(name=name, data=dict(data))

    def close(self) -> None:
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._file.close()


class _RosbagBackend:
    """A ROS 1 bag or a ROS 2 bag folder, through rosbags' writers."""

    def __init__(self, path: Path, ros1: bool, store: Typestore, storage: Ros2Storage) -> None:
        self._store = store
        self._ros1 = ros1
        if ros1:
            from rosbags.rosbag1 import Writer as Writer1

            self._writer: Any = Writer1(path)
        else:
            from rosbags.rosbag2 import StoragePlugin
            from rosbags.rosbag2 import Writer as Writer2

            plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
            self._writer = Writer2(path, version=8, storage_plugin=plugin)
        self._writer.open()
        self._connections: dict[str, tuple[Any, str]] = {}

    def add_topic(self, topic: str, msgtype: str) -> None:
        store = _ros1_store_for(msgtype, self._store) if self._ros1 else self._store
        conn = self._writer.add_connection(topic, msgtype, typestore=store)
        self._connections[topic] = (conn, msgtype)

    def write(self, topic: str, log_time_ns: int, message: object) -> None:
        conn, msgtype = self._connections[topic]
        data = _serialize(self._store, message, msgtype, self._ros1)
        self._writer.write(conn, log_time_ns, bytes(data))

    def close(self) -> None:
        self._writer.close()


class RecordingWriter:
    """Writes one recording; use :func:`open_writer` and the context manager.

    Files are written under a temporary name and renamed into place when the writer closes
    without an error, so a failed run never leaves a half-written recording. ROS 2 bag folders
    are removed again on error. The same calls always give byte-identical output.
    """

    def __init__(
        self,
        path: str | Path,
        fmt: WriterFormat,
        *,
        ros2_storage: Ros2Storage = "sqlite3",
        typestore: Typestore | None = None,
        chunk_size: int = MCAP_CHUNK_SIZE,
        compression: McapCompression = "zstd",
    ) -> None:
        if fmt not in get_args(WriterFormat):
            raise RecordingError(f"unknown recording format {fmt!r}")
        if compression not in get_args(McapCompression):
            raise RecordingError(f"unknown MCAP chunk compression {compression!r}")
        self.path = Path(path)
        self.fmt = fmt
        self._store = typestore if typestore is not None else default_typestore()
        self._topics: dict[str, str] = {}
        if self.path.exists():
            raise RecordingError(f"{self.path} exists already; not overwriting a recording")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._work = (
            self.path if fmt == "ros2" else self.path.with_name(f".{self.path.name}.partial")
        )
        if self._work.exists():
            self._work.unlink()
        self._closed = False
        try:
            self._backend: _Backend = (
                _McapBackend(self._work, fmt == "mcap-ros1", self._store, chunk_size, compression)
                if fmt in {"mcap", "mcap-ros1"}
                else _RosbagBackend(self._work, fmt == "ros1", self._store, ros2_storage)
            )
        except Exception as err:  # rosbags and OS errors on creation
            self._discard()
            raise RecordingError(f"cannot create {self.path}: {err}") from err

    def add_topic(self, topic: str, msgtype: str) -> None:
        """Declare ``topic`` with a message type in ROS 2 form (``pkg/msg/Name``).

        Raises:
            RecordingError: If the type is unknown or the topic was declared already.
        """
        msgtype = ros2_msgtype(msgtype)
        if topic in self._topics:
            raise RecordingError(f"topic {topic} was added already")
        if msgtype not in self._store.fielddefs:
            raise RecordingError(f"unknown message type {msgtype} for topic {topic}")
        self._backend.add_topic(topic, msgtype)
        self._topics[topic] = msgtype

    def write(self, topic: str, log_time_ns: int, message: object) -> None:
        """Append ``message`` (a typestore instance) on ``topic`` at ``log_time_ns`` (ns).

        Raises:
            RecordingError: If the topic was not added or the message does not serialize.
        """
        if topic not in self._topics:
            raise RecordingError(f"topic {topic} was not added before writing")
        try:
            self._backend.write(topic, int(log_time_ns), message)
        except (AttributeError, TypeError, ValueError, KeyError) as err:
            raise RecordingError(
                f"cannot serialize a message for {topic} ({self._topics[topic]}): {err}"
            ) from err

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Add a named metadata record of string pairs (MCAP formats only).

        Raises:
            RecordingError: For bag formats, which have no metadata records.
        """
        if not isinstance(self._backend, _McapBackend):
            raise RecordingError(f"metadata records are an MCAP feature; {self.fmt} has none")
        self._backend.add_metadata(name, {str(k): str(v) for k, v in data.items()})

    def close(self) -> None:
        """Finish the recording and move it into place."""
        if self._closed:
            return
        self._closed = True
        try:
            self._backend.close()
        except Exception as err:  # library errors while finishing
            self._discard()
            raise RecordingError(f"cannot finish {self.path}: {err}") from err
        if self._work != self.path:
            self._work.replace(self.path)

    def abort(self) -> None:
        """Stop writing and remove what was written."""
        if self._closed:
            return
        self._closed = True
        with contextlib.suppress(Exception):  # the output is being discarded anyway
            self._backend.close()
        self._discard()

    def _discard(self) -> None:
        if self._work.is_dir():
            shutil.rmtree(self._work, ignore_errors=True)
        elif self._work.exists():
            self._work.unlink()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def open_writer(
    path: str | Path,
    fmt: WriterFormat,
    *,
    ros2_storage: Ros2Storage = "sqlite3",
    typestore: Typestore | None = None,
    chunk_size: int = MCAP_CHUNK_SIZE,
    compression: McapCompression = "zstd",
) -> RecordingWriter:
    """Open a writer for a new recording.

    Args:
        path: Output file (``.mcap``, ``.bag``) or, for ``ros2``, the bag folder to create.
        fmt: ``mcap`` (ROS 2 CDR in MCAP), ``mcap-ros1`` (ROS 1 in MCAP), ``ros1`` (``.bag``)
            or ``ros2`` (ROS 2 bag folder).
        ros2_storage: Storage of a ``ros2`` bag: ``sqlite3`` or ``mcap``.
        typestore: Message types; by default ROS 2 Humble plus ``can_msgs/msg/Frame``.
        chunk_size: Uncompressed MCAP chunk size, bytes (MCAP formats only).
        compression: MCAP chunk compression: ``zstd``, ``lz4`` or ``none`` (MCAP formats only;
            ``none`` suits payloads that are compressed already, such as JPEG frames).

    Returns:
        The writer, to use as a context manager.

    Raises:
        RecordingError: If the path exists or the writer cannot be created.
    """
    return RecordingWriter(
        path,
        fmt,
        ros2_storage=ros2_storage,
        typestore=typestore,
        chunk_size=chunk_size,
        compression=compression,
    )


def write_protobuf_mcap(
    path: str | Path,
    items: Iterable[tuple[str, int, Any]],
    *,
    chunk_size: int = MCAP_CHUNK_SIZE,
) -> Path:
    """Write protobuf messages (e.g. Foxglove schemas) to a new MCAP file, deterministically.

    Schemas are registered with ``mcap_protobuf``'s ``register_schema`` (the file descriptor set
    of each message type), through an mcap writer whose header strings are constants.

    Args:
        path: Output ``.mcap`` file.
        items: ``(topic, log_time_ns, message)`` in the order to write; one type per topic.
        chunk_size: Uncompressed chunk size, bytes.

    Returns:
        The path written.

    Raises:
        RecordingError: If a topic changes type or the file cannot be written.
    """
    from mcap.writer import CompressionType
    from mcap.writer import Writer as McapWriter
    from mcap_protobuf.schema import register_schema

    final = Path(path)
    work = final.with_name(f".{final.name}.partial")
    channels: dict[str, tuple[int, str]] = {}
    try:
        with work.open("wb") as handle:
            writer = McapWriter(handle, chunk_size=chunk_size, compression=CompressionType.ZSTD)
            writer.start(profile="", library=LIBRARY)
            for topic, log_time_ns, message in items:
                name = type(message).DESCRIPTOR.full_name
                if topic not in channels:
                    schema_id = register_schema(writer, type(message))
                    channel_id = writer.register_channel(
                        topic=topic, message_encoding="protobuf", schema_id=schema_id
                    )
                    channels[topic] = (channel_id, name)
                channel_id, declared = channels[topic]
                if declared != name:
                    raise RecordingError(f"topic {topic} has type {declared}, not {name}")
                writer.add_message(
                    channel_id=channel_id,
                    log_time=int(log_time_ns),
                    data=message.SerializeToString(deterministic=True),
                    publish_time=int(log_time_ns),
                )
            writer.finish()  # type: ignore[no-untyped-call]
        work.replace(final)
    except OSError as err:
        raise RecordingError(f"cannot write {final}: {err.strerror}") from err
    finally:
        if work.exists():
            work.unlink()
    return final
