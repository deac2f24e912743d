"""Lenient DBC loading: load real-world DBC files that cantools refuses, recording each repair."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools.can.errors import CanError

MAX_REPAIRS = 500
"""Give up after this many repair rounds (each round fixes what one cantools error names)."""

_EXTENDED_FLAG = 0x80000000
_ID_MASK_29 = 0x1FFFFFFF


class LoadedDbc(NamedTuple):
    """A loaded DBC database and what had to be changed to load it.

    Attributes:
        database: The ``cantools.database.can.Database``.
        repairs: One human-readable line per repair or tolerated defect, in order.
    """

    database: Any
    repairs: list[str]


def _decode_text(raw: bytes, repairs: list[str]) -> str:
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
        repairs.append("decoded as latin-1 (not valid UTF-8)")
    if text.startswith("\ufeff"):
        text = text[1:]
        repairs.append("removed a UTF-8 byte-order mark")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
        repairs.append("normalised CRLF line endings")
    return text


def _drop_unused_val(text: str, message: str) -> tuple[str, list[str]] | None:
    """Drop ``VAL_`` lines that cantools lists as unused (unknown message id or signal)."""
    if "unused VAL_ entries" not in message:
        return None  # e.g. a syntax error that merely quotes a VAL_ line
    entries = re.findall(r"VAL_\s+(\d+)\s+(\w+)", message.split(":", 1)[-1])
    if not entries:
        return None
    notes = []
    for frame_id, signal in entries:
        pattern = re.compile(rf"(?m)^[ \t]*VAL_[ \t]+{frame_id}[ \t]+{signal}\b[^\n]*(\n|$)")
        text, count = pattern.subn("", text)
        if count:
            notes.append(f"dropped VAL_ table for unknown id {frame_id} signal {signal}")
    return (text, notes) if notes else None


def _fix_standard_id(text: str, message: str) -> tuple[str, list[str]] | None:
    """Declare a message extended whose id is too large for a standard frame."""
    match = re.search(
        r"Standard frame id (0x[0-9a-fA-F]+) is more than 11 bits in message (\w+)", message
    )
    if not match:
        return None
    old = int(match.group(1), 16)
    name = match.group(2)
    new = _EXTENDED_FLAG | (old & _ID_MASK_29)
    text, count = re.subn(rf"(?<![\w.]){old}(?![\w.])", str(new), text)
    if not count:
        return None
    kept = "" if old <= _ID_MASK_29 else " (masked to 29 bits)"
    note = f"declared message {name} id {old:#x} as extended id {old & _ID_MASK_29:#x}{kept}"
    return text, [note]


def _rename_duplicate_signals(text: str, database: Any) -> tuple[str, list[str]]:
    """Rename the second and later signals of the same name within one message."""
    notes: list[str] = []
    for msg in database.messages:
        names = [s.name for s in msg.signals]
        dups = {n for n in names if names.count(n) > 1}
        if not dups:
            continue
        dbc_id = msg.frame_id | (_EXTENDED_FLAG if msg.is_extended_frame else 0)
        # SG_ lines are usually indented, but DBC does not require it.
        block = re.search(
            rf"(?m)^BO_[ \t]+{dbc_id}[ \t]+{re.escape(msg.name)}\b[^\n]*\n"
            r"((?:[ \t]*SG_[^\n]*\n?)*)",
            text,
        )
        if block is None:
            continue
        body = block.group(1)
        for dup in sorted(dups):
            seen = 0

            def _sub(m: re.Match[str], dup: str = dup) -> str:
                nonlocal seen
                seen += 1
                return m.group(0) if seen == 1 else f"{m.group(1)}{dup}_{seen}{m.group(2)}"

            body, count = re.subn(rf"(SG_[ \t]+){re.escape(dup)}(\b[ \t]*[ :])", _sub, body)
            if count > 1:
                notes.append(f"renamed duplicate signal {dup} in message {msg.name} to {dup}_2..")
        text = text[: block.start(1)] + body + text[block.end(1) :]
    return text, notes


MAX_SIGNAL_BITS = 64
"""Longest signal cantools decodes (bits)."""
MAX_FRAME_BITS = 512
"""Bits in the largest CAN frame (CAN FD, 64 bytes)."""


def _drop_impossible_signals(database: Any) -> list[str]:
    """Remove signals no frame can hold (negative start bit, too long, beyond 64 bytes)."""
    notes = []
    for msg in database.messages:
        bad = [
            sig
            for sig in msg.signals
            if not 0 < sig.length <= MAX_SIGNAL_BITS
            or not 0 <= sig.start < MAX_FRAME_BITS
            or not all(0 <= bit < MAX_FRAME_BITS for bit in _signal_bits(sig))
        ]
        for sig in bad:
            msg.signals.remove(sig)
            notes.append(
                f"dropped signal {sig.name} of message {msg.name}: start bit {sig.start}, "
                f"length {sig.length} do not fit a CAN frame"
            )
        if bad:
            msg.refresh(strict=False)
    return notes


def _overlap_notes(database: Any) -> list[str]:
    """Describe overlapping non-multiplexed signals that strict loading would refuse."""
    notes = []
    for msg in database.messages:
        owner: dict[int, str] = {}
        for sig in msg.signals:
            if sig.multiplexer_ids:
                continue
            for bit in _signal_bits(sig):
                other = owner.setdefault(bit, sig.name)
                if other != sig.name:
                    notes.append(
                        f"kept overlapping signals {other} and {sig.name} in message {msg.name}"
                    )
                    break
    return notes


def _signal_bits(sig: Any) -> list[int]:
    """Return the little-endian bit positions a signal occupies (byte * 8 + bit in byte)."""
    if not 0 < sig.length <= MAX_FRAME_BITS:
        return [-1]
    if sig.byte_order == "little_endian":
        return list(range(sig.start, sig.start + sig.length))
    bits, pos = [], sig.start
    for _ in range(sig.length):
        bits.append(pos)
        pos = pos + 15 if pos % 8 == 0 else pos - 1
    return bits


def load_dbc_text(text: str, repairs: list[str] | None = None) -> LoadedDbc:
    """Load DBC text leniently, repairing what cantools refuses until it loads.

    Args:
        text: DBC file content.
        repairs: Repairs already made (e.g. while decoding the bytes); extended in place.

    Returns:
        The database and the list of repairs.

    Raises:
        CanError: If the text still cannot be loaded after the known repairs.
    """
    import cantools
    from cantools.database.errors import UnsupportedDatabaseFormatError

    notes = [] if repairs is None else repairs
    seen: set[int] = set()
    for _ in range(MAX_REPAIRS):
        if hash(text) in seen:  # a repair that undoes another: stop instead of looping
            raise CanError("DBC cannot be loaded: the repairs make no progress")
        seen.add(hash(text))
        try:
            database = cantools.database.load_string(text, database_format="dbc", strict=False)
        except (UnsupportedDatabaseFormatError, ValueError, KeyError) as err:
            reason = str(err)
            fixed = _drop_unused_val(text, reason) or _fix_standard_id(text, reason)
            if fixed is None:
                raise CanError(f"DBC cannot be loaded: {reason.strip()}") from err
            text, new_notes = fixed
            notes.extend(new_notes)
            continue
        except Exception as err:  # cantools' parser fails in other ways on malformed text
            raise CanError(f"DBC cannot be loaded: {type(err).__name__}: {err}") from err
        text, renamed = _rename_duplicate_signals(text, database)
        if renamed:
            notes.extend(renamed)
            continue
        try:
            notes.extend(_drop_impossible_signals(database))
        except Exception as err:  # cantools cannot rebuild a message's codec
            raise CanError(f"DBC cannot be loaded: {type(err).__name__}: {err}") from err
        notes.extend(_overlap_notes(database))
        return LoadedDbc(database, notes)
    raise CanError(f"DBC cannot be loaded: still failing after {MAX_REPAIRS} repairs")


def load_dbc(path: str | os.PathLike[str]) -> LoadedDbc:
    """Load a DBC file leniently (encoding, line endings, and the defects real files have).

    Repairs, each recorded: latin-1 fallback, CRLF, ``VAL_`` tables for unknown ids dropped,
    too-large standard ids declared extended, duplicate signal names renamed. Overlapping
    signals are kept (cantools' non-strict mode) and noted.

    Args:
        path: The ``.dbc`` file.

    Returns:
        The database and the repairs made.

    Raises:
        CanError: If the file cannot be read or repaired into a loadable database.
    """
    src = Path(path)
    if src.exists() and not src.is_file():  # a FIFO or device would block or never end
        raise CanError(f"{src}: cannot read DBC: not a regular file")
    try:
        raw = src.read_bytes()
    except OSError as err:
        raise CanError(f"{src}: cannot read DBC: {err.strerror}") from err
    repairs: list[str] = []
    text = _decode_text(raw, repairs)
    try:
        return load_dbc_text(text, repairs)
    except CanError as err:
        raise CanError(f"{src.name}: {err}") from err


SHIPPED_DBCS = ("slt_vehicle.dbc", "slt_mobileye_lanes.dbc")
"""DBCs shipped in ``superlane_tools/data/dbc``: the simulator's vehicle and Mobileye messages."""


def shipped_dbc(name: str) -> Path:
    """Return the path of a DBC shipped in ``superlane_tools/data/dbc``."""
    from importlib.resources import files

    return Path(str(files("superlane_tools") / "data" / "dbc" / name))


def shipped_dbcs() -> list[Path]:
    """Return the paths of every shipped DBC (:data:`SHIPPED_DBCS`)."""
    return [shipped_dbc(n) for n in SHIPPED_DBCS]
