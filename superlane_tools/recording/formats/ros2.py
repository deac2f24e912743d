"""ROS 2 bags: the folder rule (``metadata.yaml``), sqlite3 storage files and their magic."""

from __future__ import annotations

from pathlib import Path

from superlane_tools.recording.formats.probe import Probe, certain

METADATA = "metadata.yaml"
"""The file that makes a folder a ROS 2 bag."""
SQLITE_MAGIC = b"SQLite format 3\x00"
"""The first bytes of an sqlite3 database (a ROS 2 ``.db3`` storage file)."""
DB3_SUFFIX = ".db3"
LABEL = "ROS 2 bag"
NOT_A_BAG_FOLDER = f"a folder without {METADATA}"
"""Why a folder is not a recording (every other format is one file)."""


def is_bag_folder(path: Path) -> bool:
    """Return True when ``path`` is a ROS 2 bag folder (holds ``metadata.yaml``)."""
    return path.is_dir() and (path / METADATA).is_file()


def is_db3(path: Path) -> bool:
    """Return True for a file named as a ROS 2 sqlite3 storage file (``.db3``)."""
    return path.suffix == DB3_SUFFIX


def recognise(probe: Probe) -> int:
    """Return the plug-in score: certain for a bag folder or a ``.db3`` file with the magic."""
    if probe.is_dir:
        return certain(is_bag_folder(probe.path))
    return certain(probe.suffix == DB3_SUFFIX and probe.head.startswith(SQLITE_MAGIC))
