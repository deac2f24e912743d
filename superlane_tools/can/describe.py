"""A loaded DBC as plain data: messages, signals, units, enums, and the repairs made."""

from __future__ import annotations

from typing import Any

from superlane_tools.can.dbc import LoadedDbc
from superlane_tools.errors import UsageError


def _number(value: Any) -> float | int | None:
    if value is None:
        return None
    return int(value) if float(value).is_integer() else float(value)


def describe_dbc(loaded: LoadedDbc, message: str | None = None) -> dict[str, Any]:
    """Return the DBC's messages and signals as JSON-ready data, plus its repairs.

    Args:
        loaded: A DBC from :func:`~superlane_tools.can.load_dbc`.
        message: Only this message: its name, or its id in decimal or ``0x`` hex.

    Raises:
        UsageError: If ``message`` names no message of the DBC (a bad value: exit 2).
    """
    messages = sorted(loaded.database.messages, key=lambda m: m.frame_id)
    if message is not None:
        wanted = message.strip()
        try:
            as_id: int | None = int(wanted, 0)
        except ValueError:
            as_id = None
        messages = [m for m in messages if m.name == wanted or m.frame_id == as_id]
        if not messages:
            raise UsageError(f"--message: no message {message!r} in the DBC")
    out = []
    for m in messages:
        signals = []
        for s in sorted(m.signals, key=lambda s: s.start):
            choices = {str(int(k)): str(v) for k, v in (s.choices or {}).items()}
            signals.append(
                {
                    "name": s.name,
                    "start": s.start,
                    "length": s.length,
                    "byte_order": s.byte_order,
                    "is_signed": bool(s.is_signed),
                    "scale": float(s.scale),
                    "offset": float(s.offset),
                    "minimum": _number(s.minimum),
                    "maximum": _number(s.maximum),
                    "unit": s.unit or "",
                    "choices": choices,
                    "comment": s.comment or "",
                }
            )
        out.append(
            {
                "name": m.name,
                "id": m.frame_id,
                "id_hex": f"0x{m.frame_id:X}",
                "is_extended": bool(m.is_extended_frame),
                "length": m.length,
                "cycle_time_ms": m.cycle_time,
                "senders": list(m.senders or []),
                "signals": signals,
            }
        )
    return {"repairs": list(loaded.repairs), "messages": out}
