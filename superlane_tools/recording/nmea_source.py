"""NMEA 0183 logs (GGA/RMC sentences) as a streaming recording of NavSatFix-like messages."""

from __future__ import annotations

import math
import os
import re
from collections.abc import Collection, Hashable, Iterator
from datetime import UTC, date, datetime
from pathlib import Path
from typing import NamedTuple

from superlane_tools.recording.base import SkipLog, in_range
from superlane_tools.recording.decoding import Decode, RawSource
from superlane_tools.recording.errors import RecordingError
from superlane_tools.records import RawMessage, Skipped, TopicInfo

NAVSATFIX_TYPE = "sensor_msgs/msg/NavSatFix"
NMEA_TOPIC = "nmea"

_SENTENCE = re.compile(r"\$([A-Z]{2})([A-Z]{3}),([^*$]*)\*([0-9A-Fa-f]{2})")
_AT_SENTENCE = re.compile(r"\$([A-Z][A-Z0-9]{1,9}),([^*$]*)\*([0-9A-Fa-f]{2})")
"""One sentence at the start of a ``$``-piece: address (talker + type, or proprietary ``P...``),
fields, checksum."""
_PRINTABLE = re.compile(r"[\x20-\x7e]*")
_PIECES = re.compile(r"(?=\$)")
_DAY_NS = 86_400 * 1_000_000_000

# GGA fix quality -> (ROS NavSatStatus.status, assumed 1-sigma horizontal error per HDOP unit, m)
_QUALITY = {
    0: (-1, 1000.0),  # no fix
    1: (0, 4.0),  # autonomous GNSS
    2: (1, 0.5),  # differential (SBAS / DGPS)
    3: (0, 4.0),  # PPS
    4: (2, 0.02),  # RTK fixed
    5: (2, 0.5),  # RTK float
    6: (-1, 10.0),  # dead reckoning: not a GNSS fix
    7: (-1, 10.0),  # manual input
    8: (-1, 10.0),  # simulator
    9: (1, 3.0),  # WAAS / SBAS
}
COVARIANCE_TYPE_APPROXIMATED = 1
SERVICE_GPS = 1


class Stamp(NamedTuple):
    """ROS 2 style time (``sec``, ``nanosec``)."""

    sec: int
    nanosec: int


class Header(NamedTuple):
    """ROS style header with a UTC stamp and frame id."""

    stamp: Stamp
    frame_id: str


class NavSatStatus(NamedTuple):
    """``sensor_msgs/NavSatStatus``: status -1 no fix, 0 fix, 1 SBAS, 2 GBAS/RTK."""

    status: int
    service: int


class NmeaFix(NamedTuple):
    """A fix from an NMEA GGA (or RMC) sentence, field-compatible with ``NavSatFix``.

    Attributes:
        header: UTC time of the fix (RMC date + GGA time of day).
        status: ROS NavSatStatus mapped from the GGA fix quality.
        latitude: Degrees north.
        longitude: Degrees east.
        altitude: Ellipsoidal height (GGA altitude above mean sea level + geoid separation),
            metres; NaN from RMC.
        position_covariance: Row-major 3x3 ENU covariance, m^2, approximated from HDOP and
            the fix quality (vertical sigma twice the horizontal one).
        position_covariance_type: 1 (approximated) or 0 (unknown, no HDOP).
        gga_quality: GGA fix quality as sent (4 = RTK fixed, 5 = RTK float), -1 from RMC.
        hdop: Horizontal dilution of precision (NaN if absent).
        num_satellites: Satellites used (-1 if absent).
    """

    header: Header
    status: NavSatStatus
    latitude: float
    longitude: float
    altitude: float
    position_covariance: tuple[float, ...]
    position_covariance_type: int
    gga_quality: int
    hdop: float
    num_satellites: int


def nmea_checksum_ok(body: str, checksum: str) -> bool:
    """Return True when the XOR of ``body`` (between ``$`` and ``*``) equals hex ``checksum``."""
    value = 0
    for char in body.encode("ascii", errors="replace"):
        value ^= char
    return value == int(checksum, 16)


SNIFF_BYTES = 65536
"""How much of a log is looked at to recognise NMEA."""
SNIFF_LINES = 200


def nmea_lines(path: str | os.PathLike[str]) -> int:
    """Count checksummed NMEA sentences among the first lines of ``path`` (0: not NMEA).

    Looks at up to :data:`SNIFF_LINES` lines of the first :data:`SNIFF_BYTES`, so a comment
    header, a garbled or binary first line or stray NUL bytes do not hide the sentences.
    """
    src = Path(path)
    if not src.is_file():
        return 0
    try:
        with src.open("rb") as handle:
            head = handle.read(SNIFF_BYTES).decode("ascii", errors="replace")
    except OSError:
        return 0
    count = 0
    for line in head.splitlines()[:SNIFF_LINES]:
        match = _SENTENCE.search(line)
        if match and nmea_checksum_ok(f"{match[1]}{match[2]},{match[3]}", match[4]):
            count += 1
    return count


def looks_like_nmea(path: str | os.PathLike[str]) -> bool:
    """Return True when some of the first lines of ``path`` are checksummed NMEA sentences."""
    return nmea_lines(path) > 0


def _degrees(value: str, hemisphere: str) -> float:
    """Convert NMEA ``(d)ddmm.mmmm`` and a hemisphere letter to signed degrees."""
    head, _, _ = value.partition(".")
    deg_digits = len(head) - 2
    if deg_digits < 1 or hemisphere not in "NSEW" or not hemisphere:
        raise ValueError(f"bad coordinate {value!r} {hemisphere!r}")
    degrees = float(value[:deg_digits]) + float(value[deg_digits:]) / 60.0
    return -degrees if hemisphere in "SW" else degrees


def _time_of_day_ns(value: str) -> int:
    """Convert NMEA ``hhmmss.ss`` to nanoseconds since midnight."""
    if len(value) < 6:
        raise ValueError(f"bad time {value!r}")
    hours, minutes = int(value[0:2]), int(value[2:4])
    seconds = float(value[4:])
    if hours > 23 or minutes > 59 or seconds >= 61:
        raise ValueError(f"bad time {value!r}")
    return (hours * 3600 + minutes * 60) * 1_000_000_000 + round(seconds * 1e9)


def _date(value: str) -> date:
    """Convert NMEA ``ddmmyy`` to a date (years 2000-2099... 1980-2079 by GPS convention)."""
    day, month, year = int(value[0:2]), int(value[2:4]), int(value[4:6])
    return date(2000 + year if year < 80 else 1900 + year, month, day)


def _midnight_ns(day: date) -> int:
    return int(datetime(day.year, day.month, day.day, tzinfo=UTC).timestamp()) * 1_000_000_000


def _covariance(hdop: float, quality: int) -> tuple[tuple[float, ...], int]:
    if math.isnan(hdop):  # no HDOP: covariance unknown
        return (0.0,) * 9, 0
    sigma = hdop * _QUALITY.get(quality, (0, 4.0))[1]
    var_h, var_v = sigma**2, (2.0 * sigma) ** 2
    return (var_h, 0.0, 0.0, 0.0, var_h, 0.0, 0.0, 0.0, var_v), COVARIANCE_TYPE_APPROXIMATED


def _float(value: str) -> float:
    return float(value) if value else float("nan")


class _Parsed(NamedTuple):
    kind: str  # "GGA" or "RMC"
    fields: list[str]
    line: str


def _read_piece(piece: str) -> tuple[str, _Parsed | None]:
    """Read one ``$``-piece of a line: (what was damaged or "", the GGA/RMC sentence or None).

    A good sentence followed by junk (a damaged next sentence whose ``$`` was lost) is still
    returned; the junk is reported as a ``bad NMEA line``.
    """
    match = _AT_SENTENCE.match(piece)
    if match is None:
        return ("bad NMEA line" if piece.strip() else ""), None
    junk = "bad NMEA line" if piece[match.end() :].strip() else ""
    address, body = match[1], match[2]
    if not _PRINTABLE.fullmatch(body) or not nmea_checksum_ok(f"{address},{body}", match[3]):
        return "bad NMEA checksum", None
    kind = address[2:] if len(address) == 5 and not address.startswith("P") else ""
    if kind not in ("GGA", "RMC"):
        return junk, None
    return junk, _Parsed(kind, body.split(","), piece[: match.end()])


def sentence_fix(kind: str, fields: list[str], t_ns: int) -> NmeaFix:
    """Build the fix of a GGA or RMC sentence's fields at UTC time ``t_ns``.

    Raises:
        ValueError: If a field does not parse.
    """
    if kind == "RMC":
        return _fix(t_ns, fields[2:6], 1, float("nan"), -1, "nan", "", gga=False)
    quality = int(fields[5]) if fields[5] else 0
    if not 0 <= quality <= 255:
        raise ValueError(f"fix quality {quality} out of range")
    sats = int(fields[6]) if fields[6] else -1
    return _fix(t_ns, fields[1:5], quality, _float(fields[7]), sats, fields[8], fields[10])


def decode_nmea_message(raw: RawMessage) -> NmeaFix:
    """Decode a raw message of an NMEA log: a GGA or RMC sentence whose log time is the fix time.

    Raises:
        ValueError: If the payload is not a sentence whose fields parse.
    """
    match = _SENTENCE.search(raw.payload.decode("ascii"))
    if match is None:
        raise ValueError("not an NMEA sentence")
    return sentence_fix(match[2], match[3].split(","), raw.log_time_ns)


def _fix(
    t_ns: int, coords: list[str], quality: int, hdop: float, sats: int,
    altitude: str, separation: str, gga: bool = True,
) -> NmeaFix:  # fmt: skip
    if quality > 0:
        lat = _degrees(coords[0], coords[1])
        lon = _degrees(coords[2], coords[3])
    else:
        lat = lon = float("nan")
    alt = _float(altitude) + (_float(separation) if separation else 0.0)
    covariance, cov_type = _covariance(hdop, quality)
    status = _QUALITY.get(quality, (-1, 0.0))[0] if gga else 0
    stamp = Stamp(t_ns // 1_000_000_000, t_ns % 1_000_000_000)
    return NmeaFix(
        header=Header(stamp, "gnss"),
        status=NavSatStatus(status, SERVICE_GPS),
        latitude=lat,
        longitude=lon,
        altitude=alt,
        position_covariance=covariance,
        position_covariance_type=cov_type,
        gga_quality=quality if gga else -1,
        hdop=hdop,
        num_satellites=sats,
    )


class NmeaRecording(RawSource):
    """An NMEA 0183 log as a :class:`~superlane_tools.recording.base.Recording`.

    One topic, ``nmea``, of type ``sensor_msgs/msg/NavSatFix``: one message per GGA sentence
    (or per valid RMC sentence when the log has no GGA). Time is UTC: the date of the latest
    RMC (the first RMC's date for fixes before it) plus the GGA time of day, with midnight
    rollover; ``log_time_ns`` and ``stamp_ns`` are both that time. Sentences with a bad or
    missing checksum, or unparsable fields, are skipped and counted.

    Args:
        path: The NMEA text log.

    Raises:
        RecordingError: If the file does not look like NMEA or has no date (no valid RMC).
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        if not looks_like_nmea(self.path):
            raise RecordingError(f"{self.path}: not an NMEA log (no checksummed $--XXX sentence)")
        self._skips = SkipLog()
        self._first_date: date | None = None
        self._has_gga = False
        for item in self._sentences(count=False):
            if item.kind == "GGA":
                self._has_gga = True
            elif self._first_date is None and len(item.fields) >= 9 and item.fields[8]:
                try:
                    self._first_date = _date(item.fields[8])
                except ValueError:
                    continue
        if self._first_date is None:
            raise RecordingError(f"{self.path}: NMEA log without a dated RMC sentence")

    @property
    def skipped(self) -> list[Skipped]:
        """What was skipped so far: bad checksums, unparsable sentences."""
        return self._skips.items()

    def _sentences(self, count: bool = True) -> Iterator[_Parsed]:
        """Yield the GGA and RMC sentences with a good checksum; count everything damaged.

        A line is cut before every ``$``, so sentences run together by binary junk (a NUL
        where the line break was) are each read; every piece that is not one whole printable
        sentence with a good checksum (junk, a cut or garbled sentence, bytes after a
        checksum) is counted once, as ``bad NMEA line`` or ``bad NMEA checksum``.
        """
        try:
            handle = self.path.open("r", encoding="ascii", errors="replace")
        except OSError as err:
            raise RecordingError(f"{self.path}: cannot read: {err.strerror}") from err
        with handle:
            for number, line in enumerate(handle, start=1):
                for piece in _PIECES.split(line.rstrip("\r\n")):
                    what, parsed = _read_piece(piece)
                    if what and count:
                        self._skips.add(what, f"{self.path.name}: first at line {number}")
                    if parsed is not None:
                        yield parsed

    def _fixes(self) -> Iterator[tuple[NmeaFix, str]]:
        assert self._first_date is not None
        self._skips.clear()
        day_start = _midnight_ns(self._first_date)
        last_rmc_tod: int | None = None
        for item in self._sentences():
            fields = item.fields
            try:
                if item.kind == "RMC":
                    if len(fields) < 9:
                        raise ValueError("short RMC")
                    tod = _time_of_day_ns(fields[0])
                    if fields[8]:
                        day_start = _midnight_ns(_date(fields[8]))
                        last_rmc_tod = tod
                    if self._has_gga or fields[1] != "A":
                        continue
                    yield sentence_fix("RMC", fields, day_start + tod), item.line
                    continue
                if len(fields) < 11:
                    raise ValueError("short GGA")
                tod = _time_of_day_ns(fields[0])
                start = day_start
                if last_rmc_tod is not None and tod < last_rmc_tod - _DAY_NS // 2:
                    start += _DAY_NS  # GGA after midnight, before the next RMC
                yield sentence_fix("GGA", fields, start + tod), item.line
            except ValueError as err:
                self._skips.add(
                    f"unparsable NMEA {item.kind}", f"{self.path.name}: {err}: {item.line[:60]}"
                )

    def topics(self) -> list[TopicInfo]:
        """Return the single ``nmea`` topic (its count is unknown before a pass: None)."""
        return [TopicInfo(NMEA_TOPIC, NAVSATFIX_TYPE, "nmea", None)]

    def _pass_skips(self) -> SkipLog:
        return self._skips

    def _keyed_raw(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Hashable, RawMessage]]:
        """Yield each fix's source sentence as ASCII bytes (encoding ``nmea``), one key."""
        if topics is not None and NMEA_TOPIC not in topics:
            return
        for fix, line in self._fixes():
            t_ns = fix.header.stamp.sec * 1_000_000_000 + fix.header.stamp.nanosec
            if in_range(t_ns, start_ns, stop_ns):
                yield (
                    None,
                    RawMessage(NMEA_TOPIC, t_ns, NAVSATFIX_TYPE, "nmea", line.encode("ascii")),
                )

    def _decoder_for(self, key: Hashable, raw: RawMessage) -> Decode:
        """Return the sentence parser: messages are :class:`NmeaFix` objects."""
        del key, raw
        return decode_nmea_message

    def close(self) -> None:
        """Nothing stays open between iterations; present for the protocol."""
