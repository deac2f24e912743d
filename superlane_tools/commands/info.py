"""`slt info`: a recording's summary, from an MCAP's summary section or from every message."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.commands.options import ProgressBar

if TYPE_CHECKING:
    from superlane_tools.recording.inspect import CanIdStats, McapFileInfo
    from superlane_tools.recording.summary import RecordingSummary


@dataclass(frozen=True)
class InfoResult:
    """A recording's summary and where it was read from.

    Attributes:
        summary: Per-topic statistics.
        file_info: The MCAP file's own records (profile, chunks, metadata), or None.
        read_from: ``summary section`` (the fast path: nothing lost is known) or
            ``every message``.
        can_rows: Per-CAN-id statistics (every-message pass only).
    """

    summary: RecordingSummary
    file_info: McapFileInfo | None
    read_from: str
    can_rows: list[CanIdStats] = field(default_factory=list)

    @property
    def fast(self) -> bool:
        """Whether the summary came from the file's summary section alone."""
        return self.read_from == "summary section"


def run(
    recording: Path,
    scan: bool,
    progress: Callable[[int | None], AbstractContextManager[ProgressBar]],
) -> InfoResult:
    """Summarize ``recording``; an MCAP with statistics is answered from them unless ``scan``.

    Args:
        recording: The recording (any format the readers open).
        scan: Read every message even when the file has a summary section.
        progress: Opens the progress display of the every-message pass, given the total.
    """
    from superlane_tools.recording import fast_info, open_recording, summarize
    from superlane_tools.recording.inspect import (
        CAN_MSGTYPES,
        can_id_stats,
        summary_from_mcap,
    )

    file_info = fast_info(recording)
    if file_info is not None and file_info.has_statistics and not scan:
        return InfoResult(summary_from_mcap(recording, file_info), file_info, "summary section")
    with open_recording(recording) as rec:
        expected = [t.message_count for t in rec.topics()]
        total = sum(c for c in expected if c is not None) if None not in expected else None
        with progress(total) as bar:
            summary = summarize(rec, progress=bar.update)
        can_topics = [t.topic for t in summary.topics if t.msgtype in CAN_MSGTYPES]
        can_rows = can_id_stats(rec, can_topics) if can_topics else []
    return InfoResult(summary, file_info, "every message", can_rows)
