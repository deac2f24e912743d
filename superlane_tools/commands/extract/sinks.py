"""The sinks of ``slt extract``: one per stream kind, each writing its table under the output."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

from superlane_tools.can import LoadedDbc
from superlane_tools.commands.extract.config import ExtractConfig
from superlane_tools.recording import SkipLog
from superlane_tools.reporting.camera_info_sink import CameraInfoSink
from superlane_tools.reporting.can_sink import CanSink
from superlane_tools.reporting.gnss_sink import RtkSink
from superlane_tools.reporting.image_file_sink import ImageFileSink
from superlane_tools.reporting.layout import EXTRACT_FRAMES_TABLE, ExtractLayout
from superlane_tools.reporting.message_pass import MessageSink
from superlane_tools.reporting.provenance import HashedProvenance


class ExtractSinks(NamedTuple):
    """The sink of each stream kind (None: the kind is not extracted)."""

    frames: ImageFileSink | None
    camera_info: CameraInfoSink | None
    can: CanSink | None
    gnss: RtkSink | None

    def by_kind(self) -> dict[str, MessageSink | None]:
        """Return stream kind -> its sink, in the order the sinks are closed."""
        kinds = ("frames", "camera_info", "can", "gnss")
        sinks: tuple[MessageSink | None, ...] = (self.frames, self.camera_info, self.can, self.gnss)
        return dict(zip(kinds, sinks, strict=True))

    def counts(self) -> dict[str, int]:
        """Return the rows each sink wrote: frames indexed, CAN frames, signal rows, fixes."""
        return {
            "frames": self.frames.kept if self.frames else 0,
            "can_frames": self.can.frames if self.can else 0,
            "can_signals": self.can.signal_rows if self.can else 0,
            "gnss_fixes": len(self.gnss) if self.gnss else 0,
        }


def extract_sinks(
    out: Path,
    config: ExtractConfig,
    selected: Mapping[str, tuple[str, ...]],
    dbcs: dict[str, LoadedDbc],
    provenance: HashedProvenance,
    skips: SkipLog,
) -> ExtractSinks:
    """Open the sink of each selected stream kind, writing under ``out``."""
    layout = ExtractLayout(out)
    frames = selected["frames"] or selected["camera_info"]  # frames.parquet, empty or not
    return ExtractSinks(
        frames=ImageFileSink(
            out,
            config.frame_format,
            config.every,
            provenance,
            skips,
            index_name=EXTRACT_FRAMES_TABLE.file,
            images_name="frames",
        )
        if frames
        else None,
        camera_info=CameraInfoSink(layout.camera_info, provenance)
        if selected["camera_info"]
        else None,
        can=CanSink(layout.can_raw, layout.can_signals, dbcs, provenance)
        if selected["can"]
        else None,
        gnss=RtkSink(layout.rtk, config.origin, provenance) if selected["gnss"] else None,
    )
