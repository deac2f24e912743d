"""GNSS extraction: fixes to ``rtk.parquet`` with local ENU position, speed and heading."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from superlane_tools.geo import GeodeticOrigin, geodetic_to_enu, speed_heading, valid_fixes
from superlane_tools.records import Message
from superlane_tools.reporting import write_table
from superlane_tools.reporting.provenance import ProvenanceSource, resolve_provenance

RTK_SCHEMA = pa.schema(
    [
        ("topic", pa.string()),
        ("log_time_ns", pa.int64()),
        ("stamp_ns", pa.int64()),
        ("latitude_deg", pa.float64()),
        ("longitude_deg", pa.float64()),
        ("altitude_m", pa.float64()),
        ("fix_status", pa.int8()),
        ("rtk_quality", pa.int16()),  # GGA quality: any 0-255 digit string is legal
        ("covariance_m2", pa.list_(pa.float64(), 9)),
        ("covariance_type", pa.int16()),  # NavSatFix uint8: 255 is legal
        ("east_m", pa.float64()),
        ("north_m", pa.float64()),
        ("up_m", pa.float64()),
        ("speed_mps", pa.float64()),
        ("heading_rad", pa.float64()),
    ]
)


def _covariance(data: Any) -> list[float] | None:
    values = getattr(data, "position_covariance", None)
    if values is None:
        return None
    floats = [float(v) for v in values]
    return floats if len(floats) == 9 else None


class GnssSink:
    """Collects fixes (NavSatFix, Foxglove LocationFix, NMEA) and writes ``rtk.parquet``.

    GNSS rates are low (a few Hz to 20 Hz), so fixes are kept until the end: speed and heading
    need both neighbours, and the ENU origin is the first valid fix of the whole recording.

    Args:
        path: The fixes table (None: collect the rows only, :meth:`close` writes nothing).
        origin: ENU origin; None for the first valid fix (by log time over all GNSS topics).
        provenance: Provenance for the Parquet file (or a function returning it, called at
            :meth:`close`).
    """

    def __init__(
        self, path: Path | None, origin: GeodeticOrigin | None, provenance: ProvenanceSource
    ) -> None:
        self.path = path
        self.origin = origin
        self.provenance = provenance
        self.rows: list[dict[str, Any]] = []
        self.used_origin: GeodeticOrigin | None = None

    def add(self, msg: Message) -> None:
        """Collect one fix."""
        data = msg.data
        status = getattr(data, "status", None)
        fix_status = getattr(status, "status", None) if status is not None else None
        quality = getattr(data, "gga_quality", None)
        cov_type = getattr(data, "position_covariance_type", None)
        self.rows.append(
            {
                "topic": msg.topic,
                "log_time_ns": msg.log_time_ns,
                "stamp_ns": msg.stamp_ns,
                "latitude_deg": float(data.latitude),
                "longitude_deg": float(data.longitude),
                "altitude_m": float(data.altitude),
                "fix_status": None if fix_status is None else int(fix_status),
                "rtk_quality": None if quality is None or quality < 0 else int(quality),
                "covariance_m2": _covariance(data),
                "covariance_type": None if cov_type is None else int(cov_type),
            }
        )

    def close(self, ok: bool) -> list[Path]:
        """Compute ENU, speed and heading and write the table; return the files written."""
        if not ok or not self.rows or self.path is None:
            return []
        frame = pd.DataFrame(self.rows)
        frame = frame.sort_values("log_time_ns", kind="stable", ignore_index=True)
        lat = frame["latitude_deg"].to_numpy(dtype=np.float64)
        lon = frame["longitude_deg"].to_numpy(dtype=np.float64)
        alt = frame["altitude_m"].to_numpy(dtype=np.float64)
        usable = valid_fixes(lat, lon, alt)
        status = frame["fix_status"].to_numpy(dtype=np.float64, na_value=math.nan)
        usable &= ~(status < 0)  # NavSatStatus -1: no fix, whatever the numbers say
        east = np.full(len(frame), np.nan)
        north, up = east.copy(), east.copy()
        if usable.any() or self.origin is not None:
            lat_u = np.where(usable, lat, np.nan)
            enu = geodetic_to_enu(lat_u, lon, alt, self.origin)
            east, north, up = enu.east_m, enu.north_m, enu.up_m
            self.used_origin = enu.origin
        speed = np.full(len(frame), np.nan)
        heading = speed.copy()
        times = frame["log_time_ns"].to_numpy(dtype=np.int64)
        topics = frame["topic"].to_numpy()
        for topic in np.unique(topics):
            sel = topics == topic
            kin = speed_heading(times[sel], east[sel], north[sel])
            speed[sel], heading[sel] = kin.speed_mps, kin.heading_rad
        frame["east_m"], frame["north_m"], frame["up_m"] = east, north, up
        frame["speed_mps"], frame["heading_rad"] = speed, heading
        table = pa.Table.from_pandas(frame, schema=RTK_SCHEMA, preserve_index=False)
        return [write_table(table, self.path, resolve_provenance(self.provenance))]
