"""Raw CAN frames collected while a recording streams, decoded with DBCs afterwards."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from superlane_tools.can.dbc import LoadedDbc
from superlane_tools.can.decode import decode_frames, empty_signal_table
from superlane_tools.records import Message


class CanFrames:
    """Collects raw CAN frames (id, payload, log time) during the streaming pass."""

    def __init__(self) -> None:
        self.ids: list[int] = []
        self.data: list[bytes] = []
        self.times: list[int] = []

    def add(self, msg: Message) -> None:
        """Keep one ``can_msgs/msg/Frame``-like message."""
        frame = msg.data
        payload = bytes(frame.data)
        dlc = int(getattr(frame, "dlc", len(payload)))
        self.ids.append(int(frame.id) & 0x1FFFFFFF)
        self.data.append(payload[:dlc] if 0 <= dlc < len(payload) else payload)
        self.times.append(msg.log_time_ns)

    def __len__(self) -> int:
        return len(self.ids)

    def decode(self, dbcs: Mapping[str, LoadedDbc]) -> pd.DataFrame:
        """Decode every frame with every DBC; long table with a ``dbc`` column, time ordered."""
        parts = []
        if self.ids:
            ids = np.asarray(self.ids, dtype=np.uint32)
            times = np.asarray(self.times, dtype=np.int64)
            for name, loaded in dbcs.items():
                table = decode_frames(loaded.database, ids, self.data, times)
                if len(table):
                    table = table.astype({"message": str, "signal": str, "unit": str})
                    table["dbc"] = name
                    parts.append(table)
        if not parts:
            empty = empty_signal_table().astype({"message": str, "signal": str, "unit": str})
            empty["dbc"] = pd.Series(dtype=str)
            return empty
        out = pd.concat(parts, ignore_index=True)
        return out.sort_values("log_time_ns", kind="stable", ignore_index=True)
