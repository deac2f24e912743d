"""NMEA logs: the text-log suffixes whose content is voted over (NMEA sentences vs candump)."""

from __future__ import annotations

NMEA_SUFFIX = ".nmea"
TEXT_LOG_SUFFIXES = frozenset({".log", ".txt", NMEA_SUFFIX, ".trc", ".csv"})
"""Suffixes of text logs that may hold NMEA sentences (no suffix too)."""
LABEL = "NMEA log"
