"""CAN buses: which DBC decodes which bus, the ``bus`` column, and DBC coverage.

A bus is a recording's CAN topic (``/can0``, a candump channel ``can0``). A DBC is bound to a
bus with ``BUS=FILE`` (``can0=pt.dbc``); a plain ``FILE`` applies to every bus. A key matches
a topic when it equals the topic, the topic without its leading slash, or one of its path
components (``can0`` matches ``/vehicle/can0/rx``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from superlane_tools.can.dbc import LoadedDbc, load_dbc, shipped_dbcs
from superlane_tools.can.decode import decode_frames, empty_signal_table
from superlane_tools.can.errors import CanError

ALL_BUSES = "*"
"""Bus key of a DBC given without ``BUS=``: it decodes every bus."""


class DbcSpec(NamedTuple):
    """One ``--dbc`` argument: the bus it applies to (``*``: all) and the DBC file."""

    bus: str
    path: Path


class BusDbc(NamedTuple):
    """A loaded DBC and the bus it decodes (``*``: all buses)."""

    bus: str
    name: str
    loaded: LoadedDbc


def parse_dbc_spec(text: str) -> DbcSpec:
    """Parse ``BUS=FILE`` or ``FILE``.

    Raises:
        CanError: If the bus or the file name is empty.
    """
    raw = str(text)
    bus, sep, path = raw.partition("=")
    if not sep or "/" in bus or "\\" in bus or bus.endswith(".dbc"):
        return DbcSpec(ALL_BUSES, Path(raw))
    if not bus.strip() or not path.strip():
        raise CanError(f"--dbc must be FILE or BUS=FILE (e.g. can0=pt.dbc), got {raw!r}")
    return DbcSpec(bus.strip(), Path(path.strip()))


def dbc_name(spec: DbcSpec) -> str:
    """Return the name a loaded DBC goes by: its file name, ``BUS=file`` when bound to a bus."""
    return spec.path.name if spec.bus == ALL_BUSES else f"{spec.bus}={spec.path.name}"


def load_dbcs(
    specs: Sequence[str], shipped: bool = True
) -> tuple[dict[str, LoadedDbc], list[Path]]:
    """Load ``[BUS=]FILE`` DBCs, named by :func:`dbc_name`, and return them with their files.

    Args:
        specs: ``--dbc`` arguments, in order.
        shipped: With no specs, load the shipped DBCs instead of none.

    Raises:
        CanError: If a spec is malformed or a DBC cannot be loaded.
    """
    parsed = [parse_dbc_spec(p) for p in specs]
    if not parsed:
        files = shipped_dbcs() if shipped else []
        return {p.name: load_dbc(p) for p in files}, list(files)
    loaded = {dbc_name(s): load_dbc(s.path) for s in parsed}
    return loaded, [s.path for s in parsed]


def bind_dbcs(dbcs: Mapping[str, LoadedDbc]) -> list[BusDbc]:
    """Bind DBCs named ``BUS=FILE`` to their bus; plain names apply to every bus."""
    bound = []
    for name, loaded in dbcs.items():
        bus, sep, file = name.partition("=")
        bound.append(BusDbc(bus, file, loaded) if sep else BusDbc(ALL_BUSES, name, loaded))
    return bound


def bus_matches(bus: str, topic: str) -> bool:
    """Return True when the DBC bus key ``bus`` applies to the CAN ``topic``."""
    if bus == ALL_BUSES:
        return True
    stripped = topic.strip("/")
    return bus in (topic, stripped) or bus.strip("/") in stripped.split("/")


def decode_buses(
    frames: Mapping[str, tuple[Any, Sequence[bytes], Any]], dbcs: Sequence[BusDbc]
) -> pd.DataFrame:
    """Decode each bus with the DBCs bound to it.

    Args:
        frames: Topic -> ``(ids, payloads, log_time_ns)`` of that bus's frames.
        dbcs: The DBCs and their buses.

    Returns:
        The long signal table (:func:`~superlane_tools.can.decode_frames` columns) plus ``bus``
        (the topic) and ``dbc`` (the DBC's name), ordered by time (stable).
    """
    parts = []
    for topic, (ids, data, times) in frames.items():
        for spec in dbcs:
            if not bus_matches(spec.bus, topic):
                continue
            table = decode_frames(spec.loaded.database, ids, data, times)
            if len(table):
                table = table.astype({"message": str, "signal": str, "unit": str, "label": str})
                table["bus"] = topic
                table["dbc"] = spec.name
                parts.append(table)
    if not parts:
        empty = empty_signal_table().astype({"message": str, "signal": str, "unit": str})
        empty["bus"] = pd.Series(dtype=str)
        empty["dbc"] = pd.Series(dtype=str)
        return empty
    out = pd.concat(parts, ignore_index=True)
    return out.sort_values("log_time_ns", kind="stable", ignore_index=True)


class Coverage(NamedTuple):
    """How much of the CAN traffic the DBCs describe.

    Attributes:
        seen: Distinct (bus, id) pairs in the recording.
        matched: Pairs that a DBC bound to that bus knows.
        unknown_ids: Ids no bound DBC knows, each once, sorted.
        dbcs: Number of DBCs given.
    """

    seen: int
    matched: int
    unknown_ids: tuple[int, ...]
    dbcs: int

    @property
    def none_matched(self) -> bool:
        """True when DBCs were given, frames were seen and not one id matched (a wrong DBC)."""
        return self.dbcs > 0 and self.seen > 0 and self.matched == 0

    def line(self) -> str:
        """One line for logs and reports: ids matched of ids seen, unknown ids in hex."""
        shown = ", ".join(f"0x{i:X}" for i in self.unknown_ids[:40])
        more = f" (+{len(self.unknown_ids) - 40} more)" if len(self.unknown_ids) > 40 else ""
        unknown = f"; unknown ids: {shown}{more}" if self.unknown_ids else ""
        return f"DBC coverage: {self.matched} of {self.seen} CAN ids matched{unknown}"


def dbc_coverage(ids_by_topic: Mapping[str, Iterable[int]], dbcs: Sequence[BusDbc]) -> Coverage:
    """Count the ids seen per bus that a DBC bound to that bus knows.

    Args:
        ids_by_topic: Topic -> ids seen on it (any iterable, duplicates allowed).
        dbcs: The DBCs and their buses.

    Returns:
        The coverage.
    """
    seen = matched = 0
    unknown: set[int] = set()
    for topic, ids in ids_by_topic.items():
        known: set[int] = set()
        for spec in dbcs:
            if bus_matches(spec.bus, topic):
                known.update(int(m.frame_id) for m in spec.loaded.database.messages)
        distinct = {int(i) for i in np.unique(np.fromiter(ids, dtype=np.int64))}
        seen += len(distinct)
        matched += len(distinct & known)
        unknown |= distinct - known
    return Coverage(seen, matched, tuple(sorted(unknown)), len(dbcs))
