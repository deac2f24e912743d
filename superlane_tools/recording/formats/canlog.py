"""CAN logs: candump ``.log``, Vector ``.asc`` and ``.blf`` suffixes, the BLF magic."""

from __future__ import annotations

CANDUMP_SUFFIX = ".log"
"""candump ``-l`` text logs (also other text logs: the content decides)."""
ASC_SUFFIX = ".asc"
BLF_SUFFIX = ".blf"
SUFFIXES = (CANDUMP_SUFFIX, ASC_SUFFIX, BLF_SUFFIX)
"""Every suffix a CAN log the reader opens may carry."""
VECTOR_SUFFIXES = (ASC_SUFFIX, BLF_SUFFIX)
"""Suffixes that name a CAN log (their content is checked, never voted over)."""
CONVERT_SUFFIXES = (".trc", ".candump")
"""CAN logs only ``slt convert`` reads (PCAN traces, candump text under its own name)."""
BLF_MAGIC = b"LOGG"
"""The first bytes of a Vector BLF file."""
LABEL = "CAN log"
