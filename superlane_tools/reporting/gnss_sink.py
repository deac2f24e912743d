"""GNSS extraction: fixes to ``rtk.parquet`` with local ENU position, speed and heading."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from superlane_tools.geo import GeodeticOrigin, geodetic_to_enu, speed_heading, valid_fixes
from superlane_tools.records import Message
from superlane_tools.reporting import write_table
from superlane_tools.reporting.gnss_fixes import GnssCollector, GnssFixes
from superlane_tools.reporting.layout import RTK_SCHEMA
from superlane_tools.reporting.provenance import ProvenanceSource, resolve_provenance


class RtkSink:
    """Writes a pass's GNSS fixes to ``rtk.parquet``, with local ENU position, speed and heading.

    The fixes are collected by a :class:`~superlane_tools.reporting.gnss_fixes.GnssCollector`
    (tens of bytes per fix) and written at :meth:`close`.

    Args:
        path: The fixes table.
        origin: ENU origin; None for the first valid fix (by log time over all GNSS topics).
        provenance: Provenance for the Parquet file (or a function returning it, called at
            :meth:`close`).
    """

    def __init__(
        self, path: Path, origin: GeodeticOrigin | None, provenance: ProvenanceSource
    ) -> None:
        self.path = path
        self.origin = origin
        self.provenance = provenance
        self.used_origin: GeodeticOrigin | None = None
        self.collector = GnssCollector()

    def __len__(self) -> int:
        """Number of fixes collected."""
        return len(self.collector)

    def add(self, msg: Message) -> None:
        """Collect one fix."""
        self.collector.add(msg)

    def close(self, ok: bool) -> list[Path]:
        """Compute ENU, speed and heading and write the table; return the files written."""
        if not ok or not len(self):
            return []
        table = self._table(self.collector.fixes())
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
