"""CAN extraction: raw frames to ``can_raw.parquet`` and DBC-decoded signals, in bounded chunks."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from superlane_tools.can import Coverage, LoadedDbc, bind_dbcs, dbc_coverage, decode_buses
from superlane_tools.records import Message
from superlane_tools.reporting import ParquetStreamWriter
from superlane_tools.reporting.layout import CAN_RAW_SCHEMA, CAN_SIGNALS_SCHEMA
from superlane_tools.reporting.provenance import ProvenanceSource, resolve_provenance

CHUNK_ROWS = 65_536
"""CAN frames buffered before a row group is written and decoded."""


class CanSink:
    """Buffers CAN frames, writes them in row groups, and decodes each chunk with the DBCs.

    Args:
        raw_path: Table of the raw frames.
        signals_path: Table of the decoded signals (written with DBCs only).
        dbcs: Loaded DBCs by name (file name); empty for raw frames only. A name may be bound
            to a bus as ``BUS=name`` (see :mod:`superlane_tools.can.buses`); plain names apply
            to every bus (topic).
        provenance: Provenance for the Parquet files (or a function returning it, called when
            the first row group is written).
    """

    def __init__(
        self,
        raw_path: Path,
        signals_path: Path,
        dbcs: dict[str, LoadedDbc],
        provenance: ProvenanceSource,
    ) -> None:
        self.dbcs = dbcs
        self._bound = bind_dbcs(dbcs)
        self._ids: dict[str, set[int]] = {}
        self.frames = 0
        self.signal_rows = 0
        self._raw_path, self._signals_path = raw_path, signals_path
        self._provenance = provenance
        self._raw: ParquetStreamWriter | None = None
        self._signals: ParquetStreamWriter | None = None
        self._reset()

    def _open(self) -> tuple[ParquetStreamWriter, ParquetStreamWriter | None]:
        """Open the Parquet writers on first use (the provenance may still be computing)."""
        if self._raw is None:
            provenance = resolve_provenance(self._provenance)
            path = self._raw_path
            self._raw = ParquetStreamWriter(path, CAN_RAW_SCHEMA, provenance).__enter__()
            if self.dbcs:
                path = self._signals_path
                self._signals = ParquetStreamWriter(
                    path, CAN_SIGNALS_SCHEMA, provenance
                ).__enter__()
        return self._raw, self._signals

    def _reset(self) -> None:
        self._cols: dict[str, list[Any]] = {name: [] for name in CAN_RAW_SCHEMA.names}

    def add(self, msg: Message) -> None:
        """Buffer one ``can_msgs/msg/Frame``-like message."""
        frame = msg.data
        payload = bytes(frame.data)
        dlc = int(frame.dlc)
        cols = self._cols
        cols["log_time_ns"].append(msg.log_time_ns)
        cols["stamp_ns"].append(msg.stamp_ns)
        cols["topic"].append(msg.topic)
        cols["can_id"].append(int(frame.id) & 0x1FFFFFFF)
        cols["is_extended"].append(bool(frame.is_extended))
        cols["dlc"].append(dlc)
        cols["data"].append(payload[:dlc] if 0 <= dlc < len(payload) else payload)
        if len(cols["data"]) >= CHUNK_ROWS:
            self._flush()

    def _flush(self) -> None:
        cols = self._cols
        count = len(cols["data"])
        if not count:
            return
        raw, signals = self._open()
        raw.write(cols)
        self.frames += count
        topics = np.asarray(cols["topic"], dtype=object)
        ids = np.asarray(cols["can_id"], dtype=np.uint32)
        by_topic = {str(t): np.flatnonzero(topics == t) for t in np.unique(topics)}
        for topic, rows in by_topic.items():
            self._ids.setdefault(topic, set()).update(int(i) for i in np.unique(ids[rows]))
        if signals is not None:
            times = np.asarray(cols["log_time_ns"], dtype=np.int64)
            frames = {
                topic: (ids[rows], [cols["data"][i] for i in rows], times[rows])
                for topic, rows in by_topic.items()
            }
            table = decode_buses(frames, self._bound)
            if len(table):
                arrow = pa.Table.from_pandas(table, preserve_index=False)
                signals.write(arrow.select(CAN_SIGNALS_SCHEMA.names).cast(CAN_SIGNALS_SCHEMA))
                self.signal_rows += len(table)
        self._reset()

    def coverage(self) -> Coverage:
        """Return the DBC coverage of the frames seen so far (distinct ids per bus)."""
        return dbc_coverage(self._ids, self._bound)

    def close(self, ok: bool) -> list[Path]:
        """Finish the outputs (discard them when ``ok`` is False); return the files written."""
        try:
            if ok:
                self._flush()
                self._open()  # no frame at all: still write the empty tables
        except BaseException:
            ok = False
            raise
        finally:
            exc = None if ok else RuntimeError
            for writer in (self._raw, self._signals):
                if writer is not None:
                    writer.__exit__(exc, None, None)
        return [w.path for w in (self._raw, self._signals) if ok and w is not None]
