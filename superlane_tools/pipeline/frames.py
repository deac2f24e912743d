"""Camera frames from a recording as :class:`~superlane_tools.scene.InputFrame` records.

``slt segment`` and ``slt corridor`` take an image folder or a recording; this module turns a
recording's camera topic into the same frame records an image folder gives.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.errors import UsageError
from superlane_tools.pipeline.reprocess.inputs import decode_frame
from superlane_tools.recording import open_recording
from superlane_tools.records import Skipped
from superlane_tools.scene.image_folder import InputFrame

#: Message types holding camera images.
IMAGE_MSGTYPES = frozenset(
    {
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/Image",
        "foxglove.CompressedImage",
        "foxglove.RawImage",
    }
)


def is_image_folder(path: Path) -> bool:
    """Return True for a plain folder of images (a ROS 2 bag folder has ``metadata.yaml``)."""
    return path.is_dir() and not (path / "metadata.yaml").is_file()


class RecordingFrames:
    """Iterate a recording's camera frames; ``skipped`` collects what the reader lost.

    Args:
        path: Recording (MCAP, ROS 1 bag, ROS 2 bag folder).
        topic: Camera topic; the first image topic (by name) when None.

    Raises:
        RecordingError: If ``path`` is not a recording.
        UsageError: If it has no image topic, or not the one asked for.
    """

    def __init__(self, path: Path, topic: str | None = None) -> None:
        self.path = path
        self.skipped: list[Skipped] = []
        with open_recording(path) as rec:
            topics = sorted(t for t in rec.topics() if t.msgtype in IMAGE_MSGTYPES)
        if not topics:
            raise UsageError(f"{path.name}: no camera image topic")
        names = [t.topic for t in topics]
        if topic is not None and topic not in names:
            raise UsageError(f"{path.name}: no image topic {topic} (found: {', '.join(names)})")
        chosen = next(t for t in topics if topic in (None, t.topic))
        self.topic = chosen.topic
        self.total = chosen.message_count
        self._folder = re.sub(r"[^A-Za-z0-9_.-]+", "_", self.topic.strip("/")) or "camera"

    def __iter__(self) -> Iterator[InputFrame]:
        with open_recording(self.path) as rec:
            for index, msg in enumerate(rec.messages([self.topic])):
                name = f"{self._folder}/{index:06d}"
                try:
                    image = decode_frame(msg)
                except ValueError as err:
                    yield InputFrame(name, None, f"{self.topic} frame {index}: {err}")
                    continue
                yield InputFrame(name, image)
            self.skipped.extend(rec.skipped)
