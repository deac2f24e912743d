"""ROS 2 sqlite3 storage files, read read-only and row by row around damaged database pages.

rosbags reads a ``.db3`` file with one query (its open counts every message, its message query
walks the time index), so one damaged page (a cut file, a zeroed page) refuses the whole file.
Here the file is opened with rosbags when it can be; when opening or reading fails, the rows
are read again by rowid, bisecting around the damaged pages: every row whose B-tree path is
intact is kept, and the lost rowid ranges are reported per topic (count and time range).

Files are opened ``mode=ro&immutable=1``: nothing is ever written beside the input, also on a
read-only mount. The salvage reads through apsw (rosbags' sqlite binding) with a VFS that
fails a read past the end of a cut file, where sqlite would silently read zeros (a payload
whose last pages were cut off would come back with a zero tail). A page zeroed inside the
file cannot be told from data when it is the last page of a payload (sqlite keeps no page
checksums); every other damaged page is found.
"""

from __future__ import annotations

import contextlib
import shutil
import sqlite3
import tempfile
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, NamedTuple, Self

import apsw
import numpy as np

from superlane_tools.recording.base import SkipLog
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats.ros2 import is_db3
from superlane_tools.recording.times import format_utc

if TYPE_CHECKING:
    from rosbags.interfaces import Connection

ROWID_MIN = -(2**63)
ROWID_MAX = 2**63 - 1
LOST_ROWS = "unreadable sqlite3 rows"
LOST_PAYLOAD = "unreadable sqlite3 payload"


@cache
def _strict_vfs() -> str:
    """Register (once) and name the apsw VFS that fails reads past the end of a file."""

    class StrictFile(apsw.VFSFile):
        def xRead(self, amount: int, offset: int) -> bytes:  # noqa: N802 (apsw's name)
            data = super().xRead(amount, offset)
            if len(data) < amount:  # sqlite would fill the rest with zeros
                raise apsw.IOError(f"the file ends inside the page at byte {offset}")
            return data

    class StrictVFS(apsw.VFS):
        def __init__(self) -> None:
            super().__init__("slt-strict-read", "")

        def xOpen(self, name: Any, flags: list[int]) -> apsw.VFSFile:  # noqa: N802
            return StrictFile("", name, flags)

    _strict_vfs.keep = StrictVFS()  # type: ignore[attr-defined]  # apsw needs a live object
    return "slt-strict-read"


def connect_read_only(path: Path) -> Any:
    """Open a sqlite3 file read-only and immutable (apsw): no journal, WAL or shared memory.

    ``writable_schema`` makes sqlite read a file shorter than its header says (a cut file)
    instead of refusing it; nothing is written, the connection is read-only.
    """
    flags = apsw.SQLITE_OPEN_READONLY | apsw.SQLITE_OPEN_URI
    uri = f"{path.resolve().as_uri()}?mode=ro&immutable=1"
    db = apsw.Connection(uri, flags=flags, vfs=_strict_vfs())
    db.execute("PRAGMA writable_schema = ON")
    return db


class Gap(NamedTuple):
    """Rowids that could not be read: after ``after`` and before ``before`` (None: open end)."""

    after: int | None
    before: int | None


def _probe(db: Any, rowid: int) -> bool:
    """Return True when the B-tree path to ``rowid`` reads (the row need not exist)."""
    try:
        db.execute("SELECT topic_id, timestamp FROM messages WHERE id = ?", (rowid,)).fetchall()
    except apsw.Error:
        return False
    return True


def _next_readable(db: Any, bad: int) -> int | None:
    """Return the first rowid after the damaged one ``bad`` whose page reads again, or None.

    Gallops (``bad + 1, + 2, + 4, ...``) to a readable rowid, then bisects back to the first
    readable one. Rowids map to leaf pages in ranges, so a damaged page is a damaged range.
    """
    step, low = 1, bad
    while True:
        probe = min(bad + step, ROWID_MAX)
        if _probe(db, probe):
            break
        if probe == ROWID_MAX:
            return None
        low, step = probe, step * 2
    high = probe
    while high - low > 1:
        mid = (low + high) // 2
        if _probe(db, mid):
            high = mid
        else:
            low = mid
    return high


@dataclass(frozen=True)
class RowIndex:
    """The readable rows of a ``messages`` table, in ``(timestamp, rowid)`` order.

    Attributes:
        rowids: Row ids.
        topic_ids: Topic id of each row.
        times_ns: Log time of each row, ns.
        gaps: Rowid ranges that could not be read, in rowid order.
    """

    rowids: np.ndarray
    topic_ids: np.ndarray
    times_ns: np.ndarray
    gaps: tuple[Gap, ...]


def scan_rows(db: Any) -> RowIndex:
    """Read ``(rowid, topic_id, timestamp)`` of every readable row, stepping over damage.

    A table whose root page is damaged reads as one gap over every rowid.
    """
    rows: list[tuple[int, int, int]] = []
    gaps: list[Gap] = []
    low: int | None = ROWID_MIN
    query = "SELECT id, topic_id, timestamp FROM messages WHERE id >= ? ORDER BY id"
    while low is not None:
        try:
            for row in db.execute(query, (low,)):
                rowid, topic_id, timestamp = row
                if not isinstance(rowid, int) or rowid < low:  # a damaged page read as a leaf
                    raise apsw.CorruptError(f"row id {rowid} out of order")
                low = rowid + 1
                if isinstance(topic_id, int) and isinstance(timestamp, int):
                    rows.append(row)
            break
        except apsw.Error:
            nxt = _next_readable(db, low)
            after = rows[-1][0] if rows else None
            if gaps and gaps[-1].after == after:  # a second damaged page before the next row
                gaps.pop()
            gaps.append(Gap(after, nxt))
            low = nxt
    table = np.array(rows, dtype=np.int64).reshape(-1, 3)
    order = np.lexsort((table[:, 0], table[:, 2]))  # by time, then rowid (rosbags' order)
    table = table[order]
    return RowIndex(table[:, 0], table[:, 1], table[:, 2], tuple(gaps))


def _lost_in_gap(gap: Gap, ids_sorted: np.ndarray) -> int | None:
    """Return how many rows a gap lost when rowids are consecutive (rosbag2's), else None."""
    if gap.before is None:
        return None
    after = 0 if gap.after is None else gap.after
    inside = np.count_nonzero((ids_sorted > after) & (ids_sorted < gap.before))
    return int(gap.before - after - 1 - inside)


def loss_detail(
    name: str,
    index: RowIndex,
    topics: Mapping[int, str],
    expected: Mapping[str, int] | None,
    expected_total: int | None,
    cause: str = "damaged database pages",
) -> tuple[str, int]:
    """Describe what the gaps of ``index`` lost: rowids, then per topic count and time range.

    Args:
        name: Storage file name.
        index: The readable rows.
        topics: Topic name by topic id.
        expected: Messages per topic the bag's ``metadata.yaml`` declares for this file.
        expected_total: Messages the metadata declares for this file.
        cause: Why the rows are unreadable.

    Returns:
        ``(detail, lost)``: one line of text, and the number of rows lost (0 when unknown).
    """
    by_id = np.argsort(index.rowids, kind="stable")
    ids, tids, times = index.rowids[by_id], index.topic_ids[by_id], index.times_ns[by_id]
    found = len(ids)
    counted = [_lost_in_gap(g, ids) for g in index.gaps]
    lost = sum(n for n in counted if n is not None)
    if any(n is None for n in counted) and expected_total is not None:
        lost = max(lost, expected_total - found)
    spans = []
    for gap in index.gaps:
        first = "1" if gap.after is None else str(gap.after + 1)
        last = "the end" if gap.before is None else str(gap.before - 1)
        spans.append(f"{first}..{last}")
    parts = [f"{name}: rows {', '.join(spans)} unreadable ({cause})"]
    for tid, topic in sorted(topics.items(), key=lambda kv: kv[1]):
        mine = tids == tid
        count = "some"
        if expected is not None:
            declared = expected.get(topic, 0)
            if declared <= int(mine.sum()):
                continue
            count = f"{declared - int(mine.sum())} of {declared}"
        ranges = [_topic_span(gap, ids[mine], times[mine]) for gap in index.gaps]
        parts.append(f"{topic}: {count} lost {', '.join(ranges)}")
    if lost == 0 and not index.gaps:
        return "", 0
    return "; ".join(parts), lost


def _topic_span(gap: Gap, ids: np.ndarray, times: np.ndarray) -> str:
    """Return the time range of a topic a gap may have taken: its neighbours' log times."""
    before = ids[ids <= (gap.after if gap.after is not None else ROWID_MIN)]
    after = ids[ids >= (gap.before if gap.before is not None else ROWID_MAX)]
    start = format_utc(int(times[ids == before[-1]][0])) if len(before) else "the start"
    stop = format_utc(int(times[ids == after[0]][0])) if len(after) else "the end"
    return f"between {start} and {stop}"


def _has_table(db: Any, name: str) -> bool:
    """Return True when the database's schema declares table ``name`` (True if unreadable)."""
    try:
        query = "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?"
        return any(True for _ in db.execute(query, (name,)))
    except apsw.Error:
        return True


def _read_connections(db: Any, owner: object, skips: SkipLog) -> list[Connection]:
    """Return the connections of the ``topics`` table, with stored message definitions.

    Raises:
        apsw.Error: When the topics table cannot be read.
    """
    from rosbags.interfaces import (
        Connection,
        ConnectionExtRosbag2,
        MessageDefinition,
        MessageDefinitionFormat,
    )
    from rosbags.rosbag2.metadata import parse_qos

    columns = {row[1] for row in db.execute("PRAGMA table_info(topics)")}
    qos = "offered_qos_profiles" if "offered_qos_profiles" in columns else "''"
    digest = "type_description_hash" if "type_description_hash" in columns else "''"
    rows = db.execute(
        f"SELECT id, name, type, serialization_format, {qos}, {digest} FROM topics ORDER BY id"
    ).fetchall()
    formats = {"ros2msg": MessageDefinitionFormat.MSG, "ros2idl": MessageDefinitionFormat.IDL}
    msgdefs: dict[str, MessageDefinition] = {}
    try:
        for name, encoding, text in db.execute(
            "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions"
        ):
            if encoding in formats:
                msgdefs.setdefault(name, MessageDefinition(formats[encoding], text))
    except apsw.SQLError:  # no such table: a bag older than schema 4
        pass
    except apsw.Error as err:
        skips.add("unreadable message definitions", f"{err}; using the typestore", 0)
    connections = []
    for cid, topic, msgtype, serialization, qos_text, type_hash in rows:
        try:
            profiles = parse_qos(qos_text) if qos_text else []
        except Exception:  # a damaged QoS text only loses the QoS profiles
            profiles = []
        msgdef = msgdefs.get(msgtype, MessageDefinition(MessageDefinitionFormat.NONE, ""))
        ext = ConnectionExtRosbag2(serialization, profiles)
        connections.append(Connection(cid, topic, msgtype, msgdef, type_hash or "", 0, ext, owner))
    return connections


class _SalvagedRows:
    """The readable rows of one damaged storage file, served in ``(timestamp, rowid)`` order."""

    def __init__(self, db: Any, name: str, iter_skips: SkipLog) -> None:
        self._db = db
        self._name = name
        self._iter_skips = iter_skips
        self.index = scan_rows(db)

    def counts(self) -> dict[int, int]:
        """Return readable rows per topic id."""
        ids, counts = np.unique(self.index.topic_ids, return_counts=True)
        return {int(i): int(n) for i, n in zip(ids, counts, strict=True)}

    def messages(
        self,
        by_id: Mapping[int, Connection],
        start: int | None,
        stop: int | None,
        resume: tuple[int, int] | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """Yield ``(connection, log time, payload)`` of the rows of ``by_id`` in ``[start, stop)``.

        ``resume = (t, k)`` skips what a reader already yielded: every row before log time
        ``t`` and the first ``k`` rows at ``t``.
        """
        idx = self.index
        keep = np.isin(idx.topic_ids, np.fromiter(by_id, np.int64, len(by_id)))
        if start is not None:
            keep &= idx.times_ns >= start
        if stop is not None:
            keep &= idx.times_ns < stop
        if resume is not None:
            keep &= idx.times_ns >= resume[0]
        skip_at = resume[1] if resume is not None else 0
        query = "SELECT data FROM messages WHERE id = ?"
        for rowid, tid, t in zip(
            idx.rowids[keep].tolist(),
            idx.topic_ids[keep].tolist(),
            idx.times_ns[keep].tolist(),
            strict=True,
        ):
            if resume is not None and t == resume[0] and skip_at:
                skip_at -= 1
                continue
            conn = by_id[tid]
            try:
                row = self._db.execute(query, (rowid,)).fetchone()
            except apsw.Error as err:
                self._iter_skips.add(
                    LOST_PAYLOAD, f"{self._name}: {conn.topic} at {format_utc(t)}: {err}"
                )
                continue
            if row is not None and isinstance(row[0], bytes):
                yield conn, t, row[0]


class Ros2SqliteReader:
    """One ROS 2 ``.db3`` storage file: rosbags' reader, rows salvaged where it fails.

    Has the parts of ``rosbags.rosbag2.Reader`` the recording source uses: ``connections``,
    ``messages()``, ``start_time``, ``message_count``, ``path`` and the context manager. Losses
    go to ``skips`` when found at open, with the damage they describe, and to ``iter_skips`` for
    a payload lost while reading.
    """

    def __init__(
        self,
        path: Path,
        skips: SkipLog,
        iter_skips: SkipLog,
        bag_info: Mapping[str, Any] | None = None,
    ) -> None:
        """Prepare to read ``path``; ``bag_info`` is the bag's ``metadata.yaml`` mapping."""
        self.path = path
        self._skips = skips
        self._iter_skips = iter_skips
        self._bag_info = bag_info
        self._reader: Any = None
        self._db: Any | None = None
        self._rows: _SalvagedRows | None = None
        self._conns: list[Connection] = []
        self._tmp: Path | None = None

    # -- opening --------------------------------------------------------------------------

    def __enter__(self) -> Self:
        from rosbags.rosbag2 import Reader

        source = self._with_wal_merged()
        reader = Reader(source)
        try:
            reader.open()
        except Exception as err:  # rosbags refuses a damaged file whole: salvage its rows
            self._salvage(source, err)
            return self
        self._reader = reader
        self._conns = list(reader.connections)
        return self

    def _with_wal_merged(self) -> Path:
        """Return the file to read: ``path``, or a private copy with its write-ahead log merged.

        A recorder that died leaves committed messages in ``<file>-wal``; an immutable open
        ignores that file, and merging it in place would write beside the input.
        """
        wal = self.path.with_name(self.path.name + "-wal")
        if not wal.is_file() or wal.stat().st_size == 0:
            return self.path
        self._tmp = Path(tempfile.mkdtemp(prefix="slt-wal-"))
        copy = self._tmp / self.path.name
        shutil.copyfile(self.path, copy)
        shutil.copyfile(wal, copy.with_name(copy.name + "-wal"))
        try:
            with contextlib.closing(sqlite3.connect(copy)) as db:
                db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        except sqlite3.DatabaseError as err:
            self._skips.add("unreadable write-ahead log", f"{wal.name}: {err}", 0)
            copy.with_name(copy.name + "-wal").unlink(missing_ok=True)
        return copy

    def _salvage(self, source: Path, err: Exception) -> _SalvagedRows:
        """Read the rows with sqlite around the damage; report the loss per topic."""
        try:
            self._db = connect_read_only(source)
            if not self._conns:
                self._conns = _read_connections(self._db, self, self._skips)
            self._rows = _SalvagedRows(self._db, self.path.name, self._iter_skips)
        except apsw.Error as db_err:
            self.close()
            raise RecordingError(
                f"{self.path} is not a readable ROS 2 bag: {err}; salvage failed: {db_err}"
            ) from db_err
        counts = self._rows.counts()
        self._conns = [conn._replace(msgcount=counts.get(conn.id, 0)) for conn in self._conns]
        topics = {conn.id: conn.topic for conn in self._conns}
        expected, total = _declared_counts(self.path, self._bag_info)
        cause = "damaged database pages"
        if not _has_table(self._db, "messages"):
            cause = "the messages table is missing"
        detail, lost = loss_detail(self.path.name, self._rows.index, topics, expected, total, cause)
        if detail:  # else only an index or bookkeeping page was damaged: no message is lost
            self._skips.add(LOST_ROWS, detail, lost)
        return self._rows

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Close the database and remove a private copy."""
        reader, self._reader = self._reader, None
        if reader is not None:
            with contextlib.suppress(Exception):
                reader.close()
        db, self._db = self._db, None
        if db is not None:
            db.close()
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    # -- reading --------------------------------------------------------------------------

    @property
    def connections(self) -> list[Connection]:
        """The file's topics as rosbags connections."""
        return self._conns

    @property
    def start_time(self) -> int:
        """Earliest log time of the readable messages, ns (``2**63 - 1`` when none)."""
        if self._rows is None:
            return int(self._reader.start_time)
        times = self._rows.index.times_ns
        return int(times[0]) if len(times) else ROWID_MAX

    @property
    def message_count(self) -> int:
        """Messages in the file (readable ones, when salvaged)."""
        if self._rows is None:
            return int(self._reader.message_count)
        return len(self._rows.index.rowids)

    def messages(
        self,
        connections: Collection[Connection] = (),
        start: int | None = None,
        stop: int | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """Yield ``(connection, log time ns, payload)`` in log-time order, ``[start, stop)``."""
        by_id = {conn.id: conn for conn in (connections or self._conns)}
        if self._rows is not None:
            yield from self._rows.messages(by_id, start, stop)
            return
        last: int | None = None
        at_last = 0
        try:
            for conn, t, data in self._reader.messages(list(by_id.values()), start, stop):
                at_last = at_last + 1 if t == last else 1
                last = t
                yield conn, t, data
        except Exception as err:  # damage rosbags meets while reading: go on row by row
            rows = self._salvage(self._reader.path, err)
            resume = None if last is None else (last, at_last)
            yield from rows.messages(by_id, start, stop, resume)


_PER_TOPIC = (
    "SELECT topics.name, COUNT(*) FROM messages JOIN topics ON messages.topic_id = topics.id"
    " GROUP BY topics.name"
)


def _declared_counts(
    path: Path, bag_info: Mapping[str, Any] | None
) -> tuple[dict[str, int] | None, int | None]:
    """Return the messages per topic and in total that ``metadata.yaml`` declares for ``path``.

    The metadata counts messages per topic for the whole bag; in a split bag the other files'
    messages (counted in those files) are subtracted. None where that cannot be known.
    """
    if not bag_info:
        return None, None
    per_topic: dict[str, int] = {}
    with contextlib.suppress(AttributeError, TypeError, ValueError, KeyError):
        for entry in bag_info.get("topics_with_message_count", []) or []:
            per_topic[str(entry["topic_metadata"]["name"])] = int(entry["message_count"])
    if not per_topic:
        return None, None
    names = [Path(str(p)).name for p in bag_info.get("relative_file_paths", []) or []]
    for other in (path.with_name(name) for name in names if name != path.name):
        if not is_db3(other):
            return None, None
        try:
            with contextlib.closing(connect_read_only(other)) as db:
                for topic, count in db.execute(_PER_TOPIC):
                    per_topic[topic] = per_topic.get(topic, 0) - int(count)
        except apsw.Error:  # another damaged file: this one's share is unknown
            return None, None
    return per_topic, sum(per_topic.values())
