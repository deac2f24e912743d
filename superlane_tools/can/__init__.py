"""CAN: lenient DBC loading and vectorised signal decoding."""

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

__all__ = [
    "SHIPPED_DBCS",
    "SIGNAL_COLUMNS",
    "CanError",
    "FrameArrays",
    "LoadedDbc",
    "decode_frames",
    "empty_signal_table",
    "frames_to_arrays",
    "load_dbc",
    "load_dbc_text",
    "shipped_dbc",
    "shipped_dbcs",
]
