"""What ``slt filter`` returns, and its messages, shared by the MCAP and the bag filters."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from superlane_tools.recording.errors import RecordingError
from superlane_tools.records import Skipped

TopicMatch = Callable[[str], bool]
"""``f(topic) -> bool`` of the topics to keep."""
TimeResolve = Callable[[int | None], tuple[int | None, int | None]]
"""Turns a recording's first log time into the ``[start, end)`` range to keep (ns)."""
NOTHING_MATCHES = "no message matches the topics and time range; nothing written"


@dataclass(frozen=True)
class FilterResult:
    """What ``filter_recording`` wrote: messages per topic, metadata and attachments kept.

    Attributes:
        path: The output written.
        counts: Messages written per topic.
        metadata: MCAP metadata records copied (0 for bags).
        attachments: MCAP attachments copied (0 for bags).
        output_format: ``mcap``, ``ros1`` (a ``.bag``) or ``ros2`` (a bag folder).
        skipped: What could not be read from the source (damaged bag data).
    """

    path: Path
    counts: dict[str, int]
    metadata: int
    attachments: int
    output_format: str = "mcap"
    skipped: tuple[Skipped, ...] = ()


def not_filterable(src: Path) -> RecordingError:
    """Return the error for an input no reader plug-in filters."""
    return RecordingError(
        f"{src.name}: slt filter reads MCAP files and ROS bags (ROS 1 .bag, ROS 2 bag "
        "folder or .db3); convert other logs with slt convert first"
    )
