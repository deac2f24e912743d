"""Raw CAN frames collected while a recording streams, decoded per bus with DBCs afterwards."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from superlane_tools.can.buses import Coverage, bind_dbcs, dbc_coverage, decode_buses
from superlane_tools.can.dbc import LoadedDbc
from superlane_tools.records import Message

if TYPE_CHECKING:
    import pandas as pd


class CanFrames:
    """Collects raw CAN frames (id, payload, log time, bus topic) during the streaming pass."""

    def __init__(self) -> None:
        self.ids: list[int] = []
        self.data: list[bytes] = []
        self.times: list[int] = []
        self.topics: list[str] = []

    def add(self, msg: Message) -> None:
        """Keep one ``can_msgs/msg/Frame``-like message."""
        frame = msg.data
        payload = bytes(frame.data)
        dlc = int(getattr(frame, "dlc", len(payload)))
        self.ids.append(int(frame.id) & 0x1FFFFFFF)
        self.data.append(payload[:dlc] if 0 <= dlc < len(payload) else payload)
        self.times.append(msg.log_time_ns)
        self.topics.append(msg.topic)

    def __len__(self) -> int:
        return len(self.ids)

    def _by_topic(self) -> dict[str, NDArray[np.intp]]:
        topics = np.asarray(self.topics, dtype=object)
        return {str(t): np.flatnonzero(topics == t) for t in dict.fromkeys(self.topics)}

    def decode(self, dbcs: Mapping[str, LoadedDbc]) -> pd.DataFrame:
        """Decode every bus with its DBCs; long table with ``bus`` and ``dbc``, time ordered.

        A DBC name ``BUS=FILE`` applies to that bus (CAN topic) only, a plain name to all.
        """
        ids = np.asarray(self.ids, dtype=np.uint32)
        times = np.asarray(self.times, dtype=np.int64)
        frames = {
            topic: (ids[rows], [self.data[i] for i in rows], times[rows])
            for topic, rows in self._by_topic().items()
        }
        return decode_buses(frames, bind_dbcs(dbcs))

    def coverage(self, dbcs: Mapping[str, LoadedDbc]) -> Coverage:
        """Return how many of the (bus, id) pairs seen the DBCs know."""
        ids = np.asarray(self.ids, dtype=np.int64)
        by_topic = {topic: ids[rows] for topic, rows in self._by_topic().items()}
        return dbc_coverage(by_topic, bind_dbcs(dbcs))
