"""``slt filter`` for ROS bags: a trimmed ROS 1 bag, ROS 2 bag or MCAP, payloads byte for byte."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from superlane_tools.errors import UsageError
from superlane_tools.recording._filter_types import FilterResult, TimeResolve, TopicMatch
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats import mcap, ros1, ros2
from superlane_tools.recording.rosbag_source import BagKind, RosbagRecording
from superlane_tools.recording.writers import LIBRARY
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.typesys.store import Typestore

OutFormat = Literal["ros1", "ros2", "mcap"]
IDL_SEPARATOR = "=" * 80 + "\nIDL: "


def output_format(bag_kind: str, out: Path) -> OutFormat:
    """Choose the output format from ``-o``: ``.mcap`` MCAP, ``.bag`` ROS 1, else a ROS 2 folder.

    Raises:
        UsageError: When the payloads would have to be re-serialized (ROS 1 <-> ROS 2).
    """
    if out.suffix == mcap.SUFFIX:
        return "mcap"
    wanted: OutFormat = "ros1" if out.suffix == ros1.SUFFIX else "ros2"
    if wanted != bag_kind:
        have = ros1.LABEL if bag_kind == "ros1" else ros2.LABEL
        keep = "OUT.bag" if bag_kind == "ros1" else "a folder name (no suffix)"
        raise UsageError(
            f"a {have} filters to {keep} or OUT.mcap (payloads are copied, not re-serialized)"
        )
    return wanted


def filter_bag_file(
    src: Path, out: Path, match: TopicMatch, resolve: TimeResolve, kind: BagKind
) -> FilterResult:
    """Filter a ROS 1 (``ros1``) or ROS 2 (``ros2``) bag: the bag plug-ins' ``filter``.

    Raises:
        RecordingError: If the bag cannot be read or written.
        UsageError: For an impossible output format or when nothing matches.
    """
    counts, skipped = filter_bag(src, out, match, resolve, kind)
    return FilterResult(out, counts, 0, 0, output_format(kind, out), tuple(skipped))


class _BagCopier:
    """Copies ``(connection, log_time, payload)`` into a rosbags writer or an MCAP writer.

    Each source connection is registered once, with its stored message definition and hash,
    QoS profiles (ROS 2) or caller id and latching (ROS 1); definitions a ROS 2 bag does not
    store are generated from the bag's typestore.
    """

    def __init__(self, fmt: OutFormat, path: Path, source: RosbagRecording) -> None:
        self._fmt = fmt
        self._store: Typestore = source.typestore
        self._ros1 = source.kind == "ros1"
        self._map: dict[tuple[Any, ...], Any] = {}
        self._file: Any = None
        if fmt == "mcap":
            from mcap.writer import CompressionType, Writer

            self._file = path.open("wb")
            self._writer: Any = Writer(self._file, compression=CompressionType.ZSTD)
            self._writer.start(profile="ros1" if self._ros1 else "ros2", library=LIBRARY)
            self._schemas: dict[tuple[str, str], int] = {}
        elif fmt == "ros1":
            from rosbags.rosbag1 import Writer as Writer1

            self._writer = Writer1(path)
            self._writer.open()
        else:
            from rosbags.rosbag2 import StoragePlugin
            from rosbags.rosbag2 import Writer as Writer2

            plugin = StoragePlugin.MCAP if source.storage == "mcap" else StoragePlugin.SQLITE3
            self._writer = Writer2(path, version=Writer2.VERSION_LATEST, storage_plugin=plugin)
            self._writer.open()

    def _ros2_definition(self, conn: Connection) -> tuple[str, str]:
        """Return ``(msgdef, rihs01)``: the stored ones, else generated from the typestore."""
        from rosbags.interfaces import MessageDefinitionFormat

        try:
            if conn.msgdef.format == MessageDefinitionFormat.NONE or not conn.msgdef.data:
                msgdef, _ = self._store.generate_msgdef(conn.msgtype, ros_version=2)
            else:
                msgdef = conn.msgdef.data
            digest = conn.digest if conn.digest.startswith("RIHS01_") else ""
            return msgdef, digest or self._store.hash_rihs01(conn.msgtype)
        except Exception as err:  # rosbags raises its own errors for unknown types
            raise RecordingError(
                f"{conn.topic}: no message definition for {conn.msgtype} ({err}); "
                "exclude the topic with --exclude"
            ) from err

    def _target(self, conn: Connection) -> Any:
        key = (conn.topic, conn.msgtype, repr(conn.ext))
        target = self._map.get(key)
        if target is not None:
            return target
        if self._fmt == "mcap":
            target = self._mcap_channel(conn)
        elif self._fmt == "ros1":
            target = self._writer.add_connection(
                conn.topic,
                conn.msgtype,
                msgdef=conn.msgdef.data,
                md5sum=conn.digest,
                callerid=getattr(conn.ext, "callerid", None),
                latching=getattr(conn.ext, "latching", None),
            )
        else:
            msgdef, rihs01 = self._ros2_definition(conn)
            target = self._writer.add_connection(
                conn.topic,
                conn.msgtype,
                msgdef=msgdef,
                rihs01=rihs01,
                serialization_format=getattr(conn.ext, "serialization_format", "cdr"),
                offered_qos_profiles=getattr(conn.ext, "offered_qos_profiles", ()),
            )
        self._map[key] = target
        return target

    def _mcap_channel(self, conn: Connection) -> int:
        if self._ros1:
            name, encoding, msgdef = conn.msgtype.replace("/msg/", "/"), "ros1msg", conn.msgdef.data
            meta = {"md5sum": conn.digest}
            if getattr(conn.ext, "callerid", None):
                meta["callerid"] = str(conn.ext.callerid)  # type: ignore[union-attr]
            if getattr(conn.ext, "latching", None) is not None:
                meta["latching"] = str(conn.ext.latching)  # type: ignore[union-attr]
        else:
            msgdef, _ = self._ros2_definition(conn)
            name = conn.msgtype
            encoding = "ros2idl" if msgdef.startswith(IDL_SEPARATOR) else "ros2msg"
            meta = {}
        schema = self._schemas.get((name, msgdef))
        if schema is None:
            schema = self._writer.register_schema(name, encoding, msgdef.encode("utf-8"))
            self._schemas[(name, msgdef)] = schema
        return int(
            self._writer.register_channel(conn.topic, "ros1" if self._ros1 else "cdr", schema, meta)
        )

    def write(self, conn: Connection, log_time_ns: int, data: bytes) -> None:
        """Copy one message with its connection."""
        target = self._target(conn)
        if self._fmt == "mcap":
            self._writer.add_message(target, log_time_ns, data, log_time_ns)
        else:
            self._writer.write(target, log_time_ns, data)

    def close(self) -> None:
        """Finish the output (index, summary, ``metadata.yaml``)."""
        try:
            if self._fmt == "mcap":
                self._writer.finish()
            else:
                self._writer.close()
        finally:
            if self._file is not None:
                self._file.close()


def filter_bag(
    src: Path,
    out: Path,
    match: TopicMatch,
    resolve: TimeResolve,
    kind: BagKind | None = None,
) -> tuple[dict[str, int], list[Skipped]]:
    """Copy a bag's matching messages into ``out`` (format from its suffix), atomically.

    Args:
        src: ROS 1 ``.bag``, ROS 2 bag folder or ``.db3`` file.
        out: ``OUT.bag`` (ROS 1 input), ``OUT`` folder (ROS 2 input, same storage) or
            ``OUT.mcap``; must not exist.
        match: ``f(topic) -> bool`` of the topics to keep.
        resolve: Turns the bag's first log time into the ``[start, end)`` range (ns).
        kind: ``ros1`` or ``ros2`` (the reader plug-in's); None: ROS 1 for a ``.bag``.

    Returns:
        Messages written per topic, and what was skipped while reading (one line each).

    Raises:
        RecordingError: If the bag cannot be read or written.
        UsageError: For an impossible output format or when nothing matches.
    """
    with RosbagRecording(src, kind=kind) as rec:
        fmt = output_format(rec.kind, out)
        start_ns, end_ns = resolve(rec.start_ns())
        names = [t.topic for t in rec.topics() if match(t.topic)]
        if not names:
            raise UsageError("no topic matches the topic expressions; nothing written")
        work = out.parent / f".{out.name}.partial"
        try:
            work.mkdir()
        except FileExistsError as err:
            raise RecordingError(f"{work} exists: another filter is writing {out.name}") from err
        except OSError as err:
            raise RecordingError(f"cannot write {out}: {err}") from err
        counts: dict[str, int] = {}
        try:
            copier = _BagCopier(fmt, work / out.name, rec)
            try:
                for conn, log_time, data in rec.connection_messages(names, start_ns, end_ns):
                    copier.write(conn, log_time, data)
                    counts[conn.topic] = counts.get(conn.topic, 0) + 1
            finally:
                copier.close()
            if not counts:
                raise UsageError("no message matches the topics and time range; nothing written")
            (work / out.name).replace(out)
        except (UsageError, RecordingError):
            raise
        except Exception as err:  # rosbags and mcap writers raise their own errors
            raise RecordingError(f"cannot filter {src.name}: {err}") from err
        finally:
            shutil.rmtree(work, ignore_errors=True)
        skipped = rec.skipped
    return counts, skipped
