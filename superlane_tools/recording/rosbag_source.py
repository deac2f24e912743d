"""ROS 1 bags and ROS 2 bags (sqlite3 or MCAP storage, split files), read with rosbags."""

from __future__ import annotations

import contextlib
import heapq
from collections.abc import Collection, Hashable, Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from superlane_tools.config_files import load_document
from superlane_tools.errors import ConfigError
from superlane_tools.recording.base import SkipLog, raw_header_stamp_ns, storable_time
from superlane_tools.recording.decoding import Decode, DecodeFailureError, RawSource
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats import mcap, ros1
from superlane_tools.recording.formats.ros2 import METADATA, is_db3
from superlane_tools.records import RawMessage, Skipped, TopicInfo

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.typesys.store import Typestore

BagKind = Literal["ros1", "ros2"]
_ORPHANS = "SELECT COUNT(*) FROM messages WHERE topic_id NOT IN (SELECT id FROM topics)"


def _read_ros2_metadata(folder: Path) -> dict[str, Any]:
    """Return the ``rosbag2_bagfile_information`` mapping of a ROS 2 bag folder."""
    try:
        doc = load_document(folder / METADATA, "ROS 2 bag metadata", ".yaml")
        info = doc["rosbag2_bagfile_information"]
        if not isinstance(info, dict):
            raise TypeError("not a mapping")
    except (ConfigError, KeyError, TypeError) as err:
        raise RecordingError(f"{folder} is not a recording: unreadable {METADATA} ({err})") from err
    return info


class RosbagRecording(RawSource):
    """A ROS 1 ``.bag`` file, a ROS 2 bag folder or a single ``.db3`` file, for streaming.

    Message types are registered from the definitions stored in the bag; types the bag does not
    define come from the project typestore (ROS 2 Humble plus ``can_msgs``). A ROS 2 bag's files
    are read one reader per file and merged in log-time order, so split bags stream in order and
    topics match even when ``metadata.yaml`` and the storage files disagree on QoS profiles.
    """

    def __init__(self, path: str | Path, kind: BagKind | None = None) -> None:
        """Open the bag.

        Args:
            path: ``.bag`` file, ROS 2 bag folder, or ``.db3`` file.
            kind: ``ros1`` or ``ros2``; by default ``.bag`` files are ROS 1, the rest ROS 2.

        Raises:
            RecordingError: If the bag cannot be opened.
        """
        self.path = Path(path)
        self._skips = SkipLog()
        self._iter_skips = SkipLog()
        self._stack = ExitStack()
        self.kind: BagKind = kind or ("ros1" if self.path.suffix == ros1.SUFFIX else "ros2")
        self._declared: dict[str, tuple[str, int]] = {}
        readers: list[Any]
        try:
            if self.kind == "ros1":
                readers = [self._ros1_reader()]
            elif self.path.is_dir():
                readers = self._ros2_folder_readers()
            else:
                readers = [self._ros2_file_reader(self.path)]
            for reader in readers:
                self._stack.enter_context(reader)
        except RecordingError:
            self._stack.close()
            raise
        except Exception as err:  # rosbags raises its own and OS errors for bad bags
            self._stack.close()
            raise RecordingError(
                f"{self.path} is not a readable {self.kind.upper()} bag: {err}"
            ) from err
        self._readers = readers
        if self.kind == "ros2":
            self._count_orphans()
        self._encoding = "ros1" if self.kind == "ros1" else "cdr"
        self._store = self._build_typestore()
        self._header_first: dict[str, bool] = {}

    def _count_orphans(self) -> None:
        """Report messages of sqlite3 storage files whose topic id names no topic.

        rosbags joins messages with topics, so such messages would vanish without a trace.
        """
        import sqlite3

        files = [self.path] if self.path.is_file() else sorted(self.path.glob("*.db3"))
        for db3 in files:
            try:
                with contextlib.closing(
                    sqlite3.connect(f"{db3.resolve().as_uri()}?mode=ro&immutable=1", uri=True)
                ) as db:
                    (orphans,) = db.execute(_ORPHANS).fetchone()
            except sqlite3.Error:
                continue  # damage here is reported while reading
            if orphans:
                self._skips.add(
                    "message with an unknown topic id", f"{db3.name}: not readable", int(orphans)
                )

    def _ros1_reader(self) -> Any:
        """Return the rosbags reader, or a scan of the records when the index is unusable."""
        from rosbags.rosbag1 import Reader as Reader1

        from superlane_tools.recording._ros1_scan import scan_reader

        reader = Reader1(self.path)
        try:
            reader.open()
        except Exception as err:  # no index (a crashed recorder's .bag.active) or a cut file
            with contextlib.suppress(Exception):
                reader.close()
            try:
                scanned = scan_reader(self.path, self._skips)
            except (OSError, ValueError) as scan_err:
                msg = f"{self.path} is not a readable ROS 1 bag: {err}"
                raise RecordingError(msg) from scan_err
            if not scanned.connections:
                raise RecordingError(
                    f"{self.path} is not a readable ROS 1 bag: {err}; no intact data found"
                ) from err
            self._skips.add(
                "unindexed bag",
                f"{self.path.name}: {err}; messages recovered by scanning (like rosbag reindex)",
                0,
            )
            return scanned
        reader.close()
        return Reader1(self.path)

    def _ros2_folder_readers(self) -> list[Any]:
        from rosbags.rosbag2 import Reader as Reader2

        info = _read_ros2_metadata(self.path)
        for entry in info.get("topics_with_message_count", []) or []:
            meta = entry.get("topic_metadata", {})
            self._declared[str(meta.get("name"))] = (
                str(meta.get("type")),
                int(entry.get("message_count", 0)),
            )
        mode = str(info.get("compression_mode", "") or "").lower()
        files = [self.path / Path(x).name for x in info.get("relative_file_paths", []) or []]
        if mode not in {"", "none"} or not files:
            return [Reader2(self.path)]  # rosbags decompresses; one reader for the folder
        if missing := [f.name for f in files if not f.exists()]:
            raise RecordingError(f"{self.path}: bag files are missing: {', '.join(missing)}")
        return [self._ros2_file_reader(f, info) for f in files]

    def _ros2_file_reader(self, path: Path, info: dict[str, Any] | None = None) -> Any:
        """Return a reader of one storage file; ``.db3`` files are salvaged around damage."""
        from rosbags.rosbag2 import Reader as Reader2

        from superlane_tools.recording.sqlite_salvage import Ros2SqliteReader

        if is_db3(path):
            return Ros2SqliteReader(path, self._skips, self._iter_skips, info)
        return Reader2(path)

    def _build_typestore(self) -> Typestore:
        from rosbags.interfaces import MessageDefinitionFormat
        from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

        from superlane_tools.recording.typestore import default_typestore

        typs: dict[str, Any] = {}
        for conn in self._connections():
            fmt = conn.msgdef.format
            if fmt == MessageDefinitionFormat.NONE or conn.msgtype in typs:
                continue
            try:
                if fmt == MessageDefinitionFormat.MSG:
                    typs.update(get_types_from_msg(conn.msgdef.data, conn.msgtype))
                else:
                    sep = "=" * 80 + "\n"
                    for part in conn.msgdef.data.split(sep):
                        idl = part.split("\n", 1)[1] if part.startswith("IDL: ") else part
                        if idl.strip():
                            typs.update(get_types_from_idl(idl))
            except Exception as err:  # a broken stored definition: fall back to the typestore
                self._skips.add(
                    "unparsable definition",
                    f"{conn.topic} ({conn.msgtype}): {type(err).__name__}; using the typestore",
                    0,
                )
        for name, fielddef in default_typestore().fielddefs.items():
            typs.setdefault(name, fielddef)
        store = get_typestore(Stores.EMPTY)
        try:
            store.register(typs)
        except Exception as err:  # inconsistent stored definitions
            raise RecordingError(f"{self.path}: cannot register message types: {err}") from err
        return store

    def _connections(self) -> list[Connection]:
        return [conn for reader in self._readers for conn in reader.connections]

    def close(self) -> None:
        """Close every file of the bag."""
        self._stack.close()

    # -- public API ------------------------------------------------------------------------

    @property
    def skipped(self) -> list[Skipped]:
        """Problems found at open time plus those of the latest message pass."""
        return self._skips.items() + self._iter_skips.items()

    def topics(self) -> list[TopicInfo]:
        """Return one entry per topic, sorted by name, with message counts from the bag index."""
        found: dict[str, TopicInfo] = {}
        for conn in self._connections():
            known = found.get(conn.topic)
            if known is None:
                found[conn.topic] = TopicInfo(
                    conn.topic, conn.msgtype, self._encoding, conn.msgcount
                )
            else:
                count = (known.message_count or 0) + conn.msgcount
                found[conn.topic] = known._replace(message_count=count)
        for topic, (msgtype, _count) in self._declared.items():
            found.setdefault(topic, TopicInfo(topic, msgtype, self._encoding, 0))
        return [found[name] for name in sorted(found)]

    def _streams(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        names = None if topics is None else set(topics)
        streams = []
        for reader in self._readers:
            conns = [c for c in reader.connections if names is None or c.topic in names]
            if conns:
                stream = reader.messages(connections=conns, start=start_ns, stop=stop_ns)
                streams.append(self._guarded(stream, getattr(reader, "path", self.path)))
        if len(streams) == 1:
            return iter(streams[0])
        return heapq.merge(*streams, key=lambda item: item[1])

    def _guarded(
        self, stream: Iterator[tuple[Connection, int, Any]], path: Any
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """Pass a reader's messages through; end the stream at damage and report it.

        rosbags raises its own errors, ``AssertionError`` and sqlite errors (``DatabaseError``
        for a damaged page) from inside its iterators; what came before is kept.
        """
        name = Path(str(path)).name
        count = 0
        while True:
            try:
                conn, log_time, data = next(stream)
            except StopIteration:
                return
            except Exception as err:  # damaged bag data: keep what came before
                self._iter_skips.add(
                    "unreadable bag data",
                    f"{name}: after {count} messages: {type(err).__name__}: {err}; "
                    "later messages of this file are lost",
                )
                return
            if not isinstance(data, bytes | bytearray | memoryview):
                self._iter_skips.add(
                    "undecodable message", f"{conn.topic}: payload stored as {type(data).__name__}"
                )
                continue
            if not storable_time(int(log_time)):
                self._iter_skips.add("log time beyond int64 ns", conn.topic)
                continue
            count += 1
            yield conn, int(log_time), bytes(data)

    @property
    def connections(self) -> list[Connection]:
        """The rosbags connections of every file of the bag (a topic may have several)."""
        return self._connections()

    @property
    def typestore(self) -> Typestore:
        """The types the bag defines, completed with the project typestore."""
        return self._store

    @property
    def storage(self) -> Literal["ros1", "sqlite3", "mcap"]:
        """The storage format: ``ros1``, or a ROS 2 bag's ``sqlite3`` or ``mcap`` files."""
        if self.kind == "ros1":
            return "ros1"
        files = [self.path] if self.path.is_file() else list(self.path.iterdir())
        return "mcap" if any(f.suffix == mcap.SUFFIX for f in files) else "sqlite3"

    def start_ns(self) -> int | None:
        """Return the earliest log time of the bag (ns) from its index, None when empty."""
        if not all(hasattr(r, "start_time") for r in self._readers):  # a reindexing scan
            return next((t for _, t, _ in self._streams(None, None, None)), None)
        times = [int(r.start_time) for r in self._readers if getattr(r, "message_count", 1)]
        return min(times) if times else None

    def connection_messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """Yield ``(connection, log_time_ns, payload)`` in log-time order, ``[start_ns, stop_ns)``.

        Payloads are the stored bytes; for copying messages into another bag with their
        connection (message definition, hash, QoS or caller id).
        """
        self._iter_skips.clear()
        yield from self._streams(topics, start_ns, stop_ns)

    def _pass_skips(self) -> SkipLog:
        return self._iter_skips

    def _keyed_raw(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Hashable, RawMessage]]:
        """Yield ``(type name, raw message)`` in log-time order, ``[start_ns, stop_ns)``."""
        self._iter_skips.clear()
        for conn, log_time, data in self._streams(topics, start_ns, stop_ns):
            yield conn.msgtype, RawMessage(conn.topic, log_time, conn.msgtype, self._encoding, data)

    def _decoder_for(self, key: Hashable, raw: RawMessage) -> Decode:
        """Return the decoder of type name ``key``: the bag's definition, then the typestore's."""
        del raw
        msgtype = str(key)
        store = self._store
        if msgtype not in store.fielddefs:
            raise DecodeFailureError(f"no definition for {msgtype}")
        deserialize = store.deserialize_ros1 if self.kind == "ros1" else store.deserialize_cdr

        def decode(raw: RawMessage) -> Any:
            try:
                return deserialize(raw.payload, msgtype)
            except Exception:  # a placeholder definition: try the standard one of that name
                msg = self._fallback_decode(raw.payload, msgtype)
                if msg is None:
                    raise
                return msg

        return decode

    def _fallback_decode(self, data: bytes, msgtype: str) -> Any:
        """Decode with the project typestore when the bag's own definition does not fit.

        Some bags store placeholder definitions (rosbag2's own test bags do); the standard
        definition of the same type name usually decodes them.
        """
        from superlane_tools.recording.typestore import default_typestore

        store = default_typestore()
        if msgtype not in store.fielddefs:
            return None
        try:
            if self.kind == "ros1":
                return store.deserialize_ros1(data, msgtype)
            return store.deserialize_cdr(data, msgtype)
        except Exception:  # the standard definition does not fit either
            return None

    def peek_stamp_ns(self, raw: RawMessage) -> int | None:
        """Return the header stamp of ``raw`` (ns) from its first bytes, without decoding."""
        first = self._header_first.get(raw.msgtype)
        if first is None:
            fields: Any = self._store.fielddefs.get(raw.msgtype, ((), ()))[1]
            first = (
                bool(fields)
                and fields[0][0] == "header"
                and (fields[0][1][1] == "std_msgs/msg/Header")
            )
            self._header_first[raw.msgtype] = first
        return raw_header_stamp_ns(raw.encoding, raw.payload) if first else None
