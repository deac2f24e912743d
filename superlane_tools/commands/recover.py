"""``slt recover``: write the readable messages of a damaged recording into a new, valid one."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, cast

from superlane_tools.errors import UsageError
from superlane_tools.recording.errors import RecordingError

if TYPE_CHECKING:
    from superlane_tools.recording.open import ReaderPlugin

RecoverFormat = Literal["mcap", "ros1", "ros2"]


@dataclass(frozen=True)
class RecoverResult:
    """What ``recover`` wrote and what the input lost.

    Attributes:
        source: The damaged input.
        out: The recording written (same format as the input).
        format: ``mcap``, ``ros1`` or ``ros2``.
        written: Messages written per topic.
        lost: One entry per damaged region or kind of loss: ``what``, ``detail``, ``messages``
            (None when unknown) and, where the format tells them, ``start_ns`` / ``stop_ns``
            (``[start, stop)`` log times) and per-topic ``topics``.
    """

    source: Path
    out: Path
    format: RecoverFormat
    written: dict[str, int]
    lost: tuple[dict[str, Any], ...]

    def document(self) -> dict[str, Any]:
        """Return the result as a JSON-ready mapping (``slt recover --json``)."""
        return {
            "input": str(self.source),
            "output": str(self.out),
            "format": self.format,
            "messages_written": sum(self.written.values()),
            "written": dict(sorted(self.written.items())),
            "lost": list(self.lost),
        }


def _plugin(src: Path) -> ReaderPlugin:
    """Return the reader plug-in that recovers ``src``, chosen by its content.

    Raises:
        RecordingError: If ``src`` is missing or no plug-in recovers it.
    """
    from superlane_tools.recording.open import recovering_plugin

    plugin = recovering_plugin(src)
    if plugin is not None:
        return plugin
    if src.is_dir():
        from superlane_tools.recording.formats.ros2 import NOT_A_BAG_FOLDER

        raise RecordingError(f"{src} is not a recording: {NOT_A_BAG_FOLDER}")
    raise RecordingError(
        f"{src}: slt recover reads MCAP files, ROS 1 bags and ROS 2 bags (folder or .db3)"
    )


def _check_out(plugin: ReaderPlugin, src: Path, out: Path) -> None:
    if out.exists():
        raise UsageError(f"{out} exists already; not overwriting a recording")
    if out.resolve() == src.resolve():
        raise UsageError("-o must differ from the input")
    suffix = plugin.output_suffix
    if out.suffix != suffix:
        form = f"OUT{suffix}" if suffix else "a folder name OUT (no suffix)"
        raise UsageError(f"a recovered {plugin.label} is written to {form}")


def recover(src: Path, out: Path) -> RecoverResult:
    """Write every readable message of ``src`` into ``out``, in the same format, atomically.

    The reader plug-in of ``src`` (``recording.open.READERS``) recovers it: MCAP files are
    scanned record by record (``recording.scan``); bags are read by the same sources
    ``slt cat`` uses (ROS 1 reindexed by scanning when its index is unusable, ROS 2 sqlite3
    files salvaged row by row) and copied with their connections.

    Raises:
        UsageError: For an existing or wrongly named ``out``.
        RecordingError: If nothing in ``src`` is readable, or ``out`` cannot be written.
    """
    plugin = _plugin(src)
    _check_out(plugin, src, out)
    assert plugin.recover is not None
    written, lost = plugin.recover(src, out)
    if not written:
        out.unlink(missing_ok=True)
        raise RecordingError(f"{src}: no readable message; nothing written")
    return RecoverResult(src, out, cast("RecoverFormat", plugin.name), written, lost)
