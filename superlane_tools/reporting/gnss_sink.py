"""GNSS extraction: fixes to ``rtk.parquet`` with local ENU position, speed and heading."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from superlane_tools.geo import GeodeticOrigin, geodetic_to_enu, speed_heading, valid_fixes
from superlane_tools.records import Message
from superlane_tools.reporting import write_table
from superlane_tools.reporting.layout import RTK_SCHEMA
from superlane_tools.reporting.provenance import ProvenanceSource, resolve_provenance

CHUNK = 4096
"""Fixes per storage chunk of :class:`GnssSink` (a full chunk is never copied again)."""


@dataclass(frozen=True)
class GnssFixes:
    """Collected GNSS fixes as named columns, one row per fix, sorted by log time (stable).

    Nullable integer columns hold 0 where their ``has_*`` mask is False; a fix without a
    (9-element) covariance has a NaN row in ``covariance_m2``.

    Attributes:
        topics: The distinct topic names; ``topic`` indexes into it.
        topic: Topic index per fix.
        log_time_ns: Log time, integer ns.
        stamp_ns: ``header.stamp``, integer ns (valid where ``has_stamp``).
        latitude_deg: WGS84 latitude, degrees.
        longitude_deg: WGS84 longitude, degrees.
        altitude_m: Altitude, metres.
        fix_status: NavSatStatus (valid where ``has_fix_status``; -1: no fix).
        rtk_quality: GGA quality indicator (valid where ``has_rtk_quality``).
        covariance_m2: Position covariance, ENU, row-major 3x3 flattened (n, 9), m^2.
        has_covariance: Whether the fix carried a covariance.
        covariance_type: NavSatFix covariance type (valid where ``has_covariance_type``).
    """

    topics: tuple[str, ...]
    topic: NDArray[np.int32]
    log_time_ns: NDArray[np.int64]
    stamp_ns: NDArray[np.int64]
    has_stamp: NDArray[np.bool_]
    latitude_deg: NDArray[np.float64]
    longitude_deg: NDArray[np.float64]
    altitude_m: NDArray[np.float64]
    fix_status: NDArray[np.int16]
    has_fix_status: NDArray[np.bool_]
    rtk_quality: NDArray[np.int16]
    has_rtk_quality: NDArray[np.bool_]
    covariance_m2: NDArray[np.float64]
    has_covariance: NDArray[np.bool_]
    covariance_type: NDArray[np.int16]
    has_covariance_type: NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.log_time_ns.shape[0])

    def topic_names(self) -> NDArray[np.object_]:
        """Return the topic name of each fix."""
        return np.asarray(self.topics, dtype=object)[self.topic]

    def fix_status_or_nan(self) -> NDArray[np.float64]:
        """Return ``fix_status`` as floats, NaN where unknown."""
        return np.where(self.has_fix_status, self.fix_status, np.nan)

    @classmethod
    def from_rows(cls, rows: Iterable[Mapping[str, Any]]) -> GnssFixes:
        """Build fixes from row mappings with the ``rtk.parquet`` column names.

        ``topic``, ``log_time_ns`` and the three position columns are required; the others
        may be missing or None.
        """
        sink = GnssSink(None, None, None)
        for row in rows:
            sink.append(
                str(row["topic"]),
                int(row["log_time_ns"]),
                row.get("stamp_ns"),
                float(row["latitude_deg"]),
                float(row["longitude_deg"]),
                float(row["altitude_m"]),
                row.get("fix_status"),
                row.get("rtk_quality"),
                row.get("covariance_m2"),
                row.get("covariance_type"),
            )
        return sink.fixes()


class _Column:
    """A growable column in fixed-size numpy chunks: appending never copies what is stored."""

    def __init__(self, dtype: type[np.generic], width: int = 0) -> None:
        self._dtype = dtype
        self._shape: tuple[int, ...] = (CHUNK, width) if width else (CHUNK,)
        self._chunks: list[NDArray[Any]] = []
        self._used = CHUNK

    def append(self, value: Any) -> None:
        if self._used == CHUNK:
            self._chunks.append(np.zeros(self._shape, self._dtype))
            self._used = 0
        self._chunks[-1][self._used] = value
        self._used += 1

    def __len__(self) -> int:
        return (len(self._chunks) - 1) * CHUNK + self._used if self._chunks else 0

    def values(self) -> NDArray[Any]:
        if not self._chunks:
            return np.zeros((0, *self._shape[1:]), self._dtype)
        return np.concatenate([*self._chunks[:-1], self._chunks[-1][: self._used]])


def _covariance(values: Any) -> NDArray[np.float64] | None:
    if values is None:
        return None
    floats = np.array([float(v) for v in values], dtype=np.float64)
    return floats if floats.shape == (9,) else None


def _optional_int(value: Any, column: _Column, present: _Column) -> None:
    present.append(value is not None)
    column.append(0 if value is None else int(value))


class GnssSink:
    """Collects fixes (NavSatFix, Foxglove LocationFix, NMEA) and writes ``rtk.parquet``.

    Speed and heading need both neighbours, and the ENU origin is the first valid fix of the
    whole recording, so the fixes are kept until the end, as compact numpy columns (measured 75
    bytes per fix, 134 when the covariance changes with every fix: a 24 h log at 20 Hz needs
    about 130-230 MB, where a row of Python objects per fix took about 1.5 KB).

    Args:
        path: The fixes table (None: collect the fixes only, :meth:`close` writes nothing).
        origin: ENU origin; None for the first valid fix (by log time over all GNSS topics).
        provenance: Provenance for the Parquet file (or a function returning it, called at
            :meth:`close`); None only with no ``path``.
    """

    def __init__(
        self,
        path: Path | None,
        origin: GeodeticOrigin | None,
        provenance: ProvenanceSource | None,
    ) -> None:
        self.path = path
        self.origin = origin
        self.provenance = provenance
        self.used_origin: GeodeticOrigin | None = None
        self._topics: dict[str, int] = {}
        self._topic = _Column(np.int32)
        self._log_time = _Column(np.int64)
        self._stamp, self._has_stamp = _Column(np.int64), _Column(np.bool_)
        self._lat, self._lon, self._alt = (_Column(np.float64) for _ in range(3))
        self._status, self._has_status = _Column(np.int16), _Column(np.bool_)
        self._quality, self._has_quality = _Column(np.int16), _Column(np.bool_)
        self._cov_type, self._has_cov_type = _Column(np.int16), _Column(np.bool_)
        # Covariances repeat (constant, or a few values): one row per change, an index per fix.
        self._cov_rows = _Column(np.float64, 9)
        self._cov_index = _Column(np.int32)
        self._last_cov: bytes | None = None

    def __len__(self) -> int:
        """Number of fixes collected."""
        return len(self._log_time)

    def add(self, msg: Message) -> None:
        """Collect one fix."""
        data = msg.data
        status = getattr(data, "status", None)
        fix_status = getattr(status, "status", None) if status is not None else None
        quality = getattr(data, "gga_quality", None)
        self.append(
            msg.topic,
            msg.log_time_ns,
            msg.stamp_ns,
            float(data.latitude),
            float(data.longitude),
            float(data.altitude),
            fix_status,
            None if quality is None or quality < 0 else quality,
            getattr(data, "position_covariance", None),
            getattr(data, "position_covariance_type", None),
        )

    def append(
        self,
        topic: str,
        log_time_ns: int,
        stamp_ns: int | None,
        latitude_deg: float,
        longitude_deg: float,
        altitude_m: float,
        fix_status: int | None,
        rtk_quality: int | None,
        covariance_m2: Iterable[float] | None,
        covariance_type: int | None,
    ) -> None:
        """Collect one fix from its field values (None: unknown)."""
        self._topic.append(self._topics.setdefault(topic, len(self._topics)))
        self._log_time.append(log_time_ns)
        _optional_int(stamp_ns, self._stamp, self._has_stamp)
        self._lat.append(latitude_deg)
        self._lon.append(longitude_deg)
        self._alt.append(altitude_m)
        _optional_int(fix_status, self._status, self._has_status)
        _optional_int(rtk_quality, self._quality, self._has_quality)
        _optional_int(covariance_type, self._cov_type, self._has_cov_type)
        cov = _covariance(covariance_m2)
        key = None if cov is None else cov.tobytes()
        if key is None:
            self._cov_index.append(-1)
        else:
            if key != self._last_cov:
                self._cov_rows.append(cov)
                self._last_cov = key
            self._cov_index.append(len(self._cov_rows) - 1)

    def fixes(self) -> GnssFixes:
        """Return the fixes collected so far, sorted by log time (stable)."""
        log_time = self._log_time.values()
        order = np.argsort(log_time, kind="stable")
        cov_index = self._cov_index.values()[order]
        has_cov = cov_index >= 0
        cov_rows = self._cov_rows.values()
        cov = np.full((len(order), 9), np.nan)
        cov[has_cov] = cov_rows[cov_index[has_cov]]
        return GnssFixes(
            topics=tuple(self._topics),
            topic=self._topic.values()[order],
            log_time_ns=log_time[order],
            stamp_ns=self._stamp.values()[order],
            has_stamp=self._has_stamp.values()[order],
            latitude_deg=self._lat.values()[order],
            longitude_deg=self._lon.values()[order],
            altitude_m=self._alt.values()[order],
            fix_status=self._status.values()[order],
            has_fix_status=self._has_status.values()[order],
            rtk_quality=self._quality.values()[order],
            has_rtk_quality=self._has_quality.values()[order],
            covariance_m2=cov,
            has_covariance=has_cov,
            covariance_type=self._cov_type.values()[order],
            has_covariance_type=self._has_cov_type.values()[order],
        )

    def close(self, ok: bool) -> list[Path]:
        """Compute ENU, speed and heading and write the table; return the files written."""
        if not ok or not len(self) or self.path is None:
            return []
        assert self.provenance is not None, "a sink that writes needs provenance"
        table = self._table(self.fixes())
        return [write_table(table, self.path, resolve_provenance(self.provenance))]

    def _table(self, fx: GnssFixes) -> pa.Table:
        n = len(fx)
        lat, lon, alt = fx.latitude_deg, fx.longitude_deg, fx.altitude_m
        usable = valid_fixes(lat, lon, alt)
        usable &= ~(fx.fix_status_or_nan() < 0)  # NavSatStatus -1: no fix, whatever the numbers
        east = np.full(n, np.nan)
        north, up = east.copy(), east.copy()
        if usable.any() or self.origin is not None:
            enu = geodetic_to_enu(np.where(usable, lat, np.nan), lon, alt, self.origin)
            east, north, up = enu.east_m, enu.north_m, enu.up_m
            self.used_origin = enu.origin
        speed = np.full(n, np.nan)
        heading = speed.copy()
        for code in np.unique(fx.topic):
            sel = fx.topic == code
            kin = speed_heading(fx.log_time_ns[sel], east[sel], north[sel])
            speed[sel], heading[sel] = kin.speed_mps, kin.heading_rad

        # NaN is null, as pandas has it (the table was built with pa.Table.from_pandas)
        def floats(values: NDArray[np.float64]) -> pa.Array:
            return pa.array(values, from_pandas=True)

        covariance = pa.FixedSizeListArray.from_arrays(
            floats(fx.covariance_m2.reshape(-1)), 9, mask=pa.array(~fx.has_covariance)
        )
        columns = [
            pa.DictionaryArray.from_arrays(
                pa.array(fx.topic), pa.array(fx.topics, pa.string())
            ).cast(pa.string()),
            pa.array(fx.log_time_ns),
            pa.array(fx.stamp_ns, mask=~fx.has_stamp),
            floats(lat),
            floats(lon),
            floats(alt),
            pa.array(fx.fix_status, mask=~fx.has_fix_status).cast(pa.int8()),
            pa.array(fx.rtk_quality, mask=~fx.has_rtk_quality),
            covariance,
            pa.array(fx.covariance_type, mask=~fx.has_covariance_type),
            floats(east),
            floats(north),
            floats(up),
            floats(speed),
            floats(heading),
        ]
        return pa.Table.from_arrays(columns, schema=RTK_SCHEMA)
