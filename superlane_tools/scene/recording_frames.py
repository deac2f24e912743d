"""Camera frames from a recording as :class:`~superlane_tools.scene.InputFrame` records.

``slt segment`` and ``slt corridor`` take an image folder or a recording; this module turns a
recording's camera topic into the same frame records an image folder gives.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from superlane_tools.errors import UsageError
from superlane_tools.recording import FRAME_TYPES, check_topic_kinds, open_recording
from superlane_tools.recording.camera_frames import camera_frames
from superlane_tools.recording.open import is_recording_folder
from superlane_tools.records import Skipped
from superlane_tools.scene.image_folder import InputFrame, folder_frames, list_images


def is_image_folder(path: Path) -> bool:
    """Return True for a plain folder of images (not a folder a reader plug-in reads)."""
    return path.is_dir() and not is_recording_folder(path)


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
            listed = rec.topics()
        if topic is not None:
            check_topic_kinds(listed, {"frames": [topic]}, "--topic: ")
        topics = sorted(t for t in listed if t.msgtype in FRAME_TYPES)
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
            for index, frame in enumerate(camera_frames(rec, self.topic)):
                name = f"{self._folder}/{index:06d}"
                if frame.image is None:
                    problem = f"{self.topic} frame {index}: {frame.error}"
                    yield InputFrame(name, None, problem, frame.log_time_ns)
                    continue
                yield InputFrame(name, frame.image, "", frame.log_time_ns)
            self.skipped.extend(rec.skipped)


class InputFrames:
    """The frames of ``slt segment`` / ``slt corridor`` INPUT: an image folder or a recording.

    Attributes:
        total: Number of frames when known up front (for progress bars), else None.
        skipped: What the recording reader lost (filled while iterating; empty for folders).

    Raises:
        UsageError: If INPUT does not exist, equals ``out``, or is a folder without images.
        RecordingError: If INPUT is a file that is not a recording.
    """

    def __init__(self, input_path: Path, out: Path) -> None:
        if not input_path.exists():
            raise UsageError(f"input not found: {input_path}")
        if out.resolve() == input_path.resolve():
            raise UsageError("--out must differ from INPUT (outputs would overwrite the inputs)")
        self._recording: RecordingFrames | None = None
        self._frames: Iterator[InputFrame]
        self.total: int | None
        if is_image_folder(input_path):
            images = list_images(input_path, exclude=out)
            if not images:
                raise UsageError(f"no PNG or JPEG images under {input_path}")
            self._frames, self.total = folder_frames(input_path, images), len(images)
        else:
            self._recording = RecordingFrames(input_path)
            self._frames, self.total = iter(self._recording), self._recording.total

    @property
    def skipped(self) -> list[Skipped]:
        """Return what the recording reader reported lost (empty for folders)."""
        return self._recording.skipped if self._recording is not None else []

    def __iter__(self) -> Iterator[InputFrame]:
        return self._frames
