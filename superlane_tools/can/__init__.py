"""CAN: lenient DBC loading and vectorised signal decoding."""

from superlane_tools.can.buses import (
    ALL_BUSES,
    BusDbc,
    Coverage,
    DbcSpec,
    bind_dbcs,
    bus_matches,
    dbc_coverage,
    dbc_name,
    decode_buses,
    load_dbcs,
    parse_dbc_spec,
)
from superlane_tools.can.dbc import (
    SHIPPED_DBCS,
    LoadedDbc,
    load_dbc,
    load_dbc_text,
    shipped_dbc,
    shipped_dbcs,
)
from superlane_tools.can.decode import (
    SIGNAL_COLUMNS,
    FrameArrays,
    decode_frames,
    empty_signal_table,
    frames_to_arrays,
)
from superlane_tools.can.errors import CanError
from superlane_tools.can.mobileye import (
    MAPPINGS,
    Latency,
    MobileyeMapping,
    latency_by_xcorr,
    line_latency,
    mobileye_table,
    unwrap_relabels,
)
from superlane_tools.can.units import SPEED_UNITS, YAW_RATE_UNITS, si_factor, to_si

__all__ = [
    "ALL_BUSES",
    "MAPPINGS",
    "SHIPPED_DBCS",
    "SIGNAL_COLUMNS",
    "SPEED_UNITS",
    "YAW_RATE_UNITS",
    "BusDbc",
    "CanError",
    "Coverage",
    "DbcSpec",
    "FrameArrays",
    "Latency",
    "LoadedDbc",
    "MobileyeMapping",
    "bind_dbcs",
    "bus_matches",
    "dbc_coverage",
    "dbc_name",
    "decode_buses",
    "decode_frames",
    "empty_signal_table",
    "frames_to_arrays",
    "latency_by_xcorr",
    "line_latency",
    "load_dbc",
    "load_dbc_text",
    "load_dbcs",
    "mobileye_table",
    "parse_dbc_spec",
    "shipped_dbc",
    "shipped_dbcs",
    "si_factor",
    "to_si",
    "unwrap_relabels",
]
