"""A dashcam video file (MP4, MKV, MOV, AVI, WebM) opened as a recording.

The video is converted once per process by :func:`~superlane_tools.recording.convert.convert`
(``slt convert``'s machinery: H.264/H.265 packets copied, other codecs and B-frame streams
re-encoded) into a temporary MCAP holding ``foxglove_msgs/msg/CompressedVideo`` on
``/camera/video``, which every command then reads like any recording. The temporary file lives
in the system's temporary folder (``TMPDIR``), never beside the video (inputs are read-only),
and is removed when the process exits; it is about the size of the video when the packets are
copied. Frame times are seconds into the video from the container's ``creation_time`` (else
from 0). GNSS, CAN or signal logs recorded with the video are joined by ``slt convert``.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from collections.abc import Collection, Iterator
from pathlib import Path

from superlane_tools.recording.base import ClosingRecording
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats import mcap
from superlane_tools.records import Message, RawMessage, Skipped, TopicInfo

_converted: dict[tuple[str, int, int], tuple[Path, list[str], list[Skipped]]] = {}
_folders: list[Path] = []


def _remove_folders() -> None:
    for folder in _folders:
        shutil.rmtree(folder, ignore_errors=True)


def _convert_once(path: Path) -> tuple[Path, list[str], list[Skipped]]:
    """Return the temporary MCAP of ``path``, converting it on first use in this process."""
    from superlane_tools.recording.convert import ConvertConfig, ConvertInput, convert

    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    if key in _converted and _converted[key][0].is_file():
        return _converted[key]
    if not _folders:
        atexit.register(_remove_folders)
    folder = Path(tempfile.mkdtemp(prefix="slt-video-"))
    _folders.append(folder)
    out = folder / f"{path.stem}{mcap.SUFFIX}"
    command = f"slt opened the video {path.name} as a recording (slt convert {path.name})"
    try:
        result = convert([ConvertInput(path, "video")], out, ConvertConfig(), command=command)
    except OSError as err:
        raise RecordingError(f"{path}: cannot convert the video: {err.strerror}") from err
    _converted[key] = (out, result.notes, result.skipped)
    return _converted[key]


class VideoFileRecording(ClosingRecording):
    """A video file read as a recording with one camera topic (``/camera/video``).

    Args:
        path: The video file.

    Raises:
        RecordingError: If the file holds no readable video stream.
    """

    def __init__(self, path: str | Path) -> None:
        from superlane_tools.recording.mcap_source import McapRecording

        self.path = Path(path)
        self.kind = "video"
        """Container kind (``slt info`` shows it)."""
        mcap, notes, skipped = _convert_once(self.path)
        self.notes: list[str] = list(notes)
        """What the conversion did (packets copied or re-encoded)."""
        self._convert_skipped = list(skipped)
        self._inner = McapRecording(mcap)

    @property
    def skipped(self) -> list[Skipped]:
        """What was skipped while converting and reading."""
        return [*self._convert_skipped, *self._inner.skipped]

    def topics(self) -> list[TopicInfo]:
        """Return the video topic."""
        return self._inner.topics()

    def messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[Message]:
        """Yield the decoded ``CompressedVideo`` messages in the range."""
        return self._inner.messages(topics, start_ns, stop_ns)

    def raw_messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[RawMessage]:
        """Yield the undecoded messages in the range."""
        return self._inner.raw_messages(topics, start_ns, stop_ns)

    def peek_stamp_ns(self, raw: RawMessage) -> int | None:
        """Return the header stamp (ns) of a raw message of the temporary MCAP."""
        return self._inner.peek_stamp_ns(raw)

    def metadata(self) -> dict[str, dict[str, str]]:
        """Return the ``slt_convert`` record: how the video was read, its time alignment."""
        return self._inner.metadata()

    def close(self) -> None:
        """Close the temporary MCAP (removed when the process exits)."""
        self._inner.close()
