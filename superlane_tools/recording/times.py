"""Times as users type them: seconds into a recording, ISO 8601 instants, or epoch nanoseconds."""

from __future__ import annotations

import math
import re
from datetime import UTC, datetime
from typing import NamedTuple

from superlane_tools.errors import UsageError

_NS = 1_000_000_000
_SECONDS = re.compile(r"^[+-]?(\d+(\.\d*)?|\.\d+)(e[+-]?\d+)?s?$", re.IGNORECASE)
_EPOCH_NS = re.compile(r"^\d{16,20}(ns)?$|^\d+ns$")
_ISO_HINT = re.compile(r"^\d{4}-\d{2}-\d{2}")


class TimeSpec(NamedTuple):
    """A parsed time: absolute (ns since the Unix epoch) or relative (ns after a reference).

    Attributes:
        ns: The time, integer nanoseconds.
        absolute: True for an instant on the recording's clock, False for an offset from its
            first message.
    """

    ns: int
    absolute: bool

    def resolve(self, first_ns: int) -> int:
        """Return the absolute time (ns) given the recording's first log time (ns)."""
        return self.ns if self.absolute else first_ns + self.ns


_MAX_OFFSET_S = 9e9
"""Largest offset in seconds (int64 nanoseconds hold about 292 years)."""


def parse_time(text: str, option: str = "time") -> TimeSpec:
    """Parse a time as a user types it.

    Accepted: seconds after the recording's first message (``12.5``, ``12.5s``); an ISO 8601
    instant (``2018-08-02T15:34:47Z``, ``2018-08-02 15:34:47.250+02:00``; no zone means UTC);
    nanoseconds since the Unix epoch (an integer of 16 or more digits, or any integer ending in
    ``ns``).

    Args:
        text: What the user typed.
        option: Name of the option, for the error message.

    Raises:
        UsageError: If the text is none of these.
    """
    value = text.strip()
    if _EPOCH_NS.match(value):
        ns = int(value.removesuffix("ns"))
        if not 0 <= ns < 2**64:
            raise UsageError(f"{option}: {text!r} is outside the range of uint64 nanoseconds")
        return TimeSpec(ns, True)
    if _SECONDS.match(value):
        seconds = float(value.rstrip("sS"))
        if not (math.isfinite(seconds) and abs(seconds) <= _MAX_OFFSET_S):
            raise UsageError(
                f"{option}: {text!r} is not a finite offset of at most {_MAX_OFFSET_S:g} s"
            )
        return TimeSpec(round(seconds * _NS), False)
    if _ISO_HINT.match(value):
        try:
            instant = datetime.fromisoformat(value.replace("Z", "+00:00"))
        except ValueError as err:
            raise UsageError(f"{option}: cannot read {text!r} as an ISO 8601 time: {err}") from err
        if instant.tzinfo is None:
            instant = instant.replace(tzinfo=UTC)
        delta = instant - datetime(1970, 1, 1, tzinfo=UTC)
        ns = (delta.days * 86_400 + delta.seconds) * _NS + delta.microseconds * 1000
        return TimeSpec(ns, True)
    raise UsageError(
        f"{option}: {text!r} is not a time (seconds like 12.5, ISO 8601 like "
        "2018-08-02T15:34:47Z, or epoch nanoseconds)"
    )


def format_utc(ns: int) -> str:
    """Return an ISO 8601 UTC string with nanoseconds for ``ns`` since the epoch."""
    seconds, rest = divmod(int(ns), _NS)
    base = datetime.fromtimestamp(seconds, tz=UTC).strftime("%Y-%m-%dT%H:%M:%S")
    return f"{base}.{rest:09d}Z"
