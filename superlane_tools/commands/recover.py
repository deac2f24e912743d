"""``slt recover``: write the readable messages of a damaged recording into a new, valid one."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from superlane_tools.errors import UsageError
from superlane_tools.recording.errors import RecordingError

RecoverFormat = Literal["mcap", "ros1", "ros2"]
_OUT_FORM = {"mcap": "OUT.mcap", "ros1": "OUT.bag", "ros2": "a folder name OUT (no suffix)"}
_NAMES = {"mcap": "MCAP file", "ros1": "ROS 1 bag", "ros2": "ROS 2 bag"}


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


def input_format(src: Path) -> RecoverFormat:
    """Return the format of ``src`` from its content: MCAP, ROS 1 bag or ROS 2 bag.

    Raises:
        RecordingError: If ``src`` is missing or none of these.
    """
    from superlane_tools.recording.open import ROS1_MAGIC, SQLITE_MAGIC

    if src.is_dir():
        if (src / "metadata.yaml").is_file():
            return "ros2"
        raise RecordingError(f"{src} is not a recording: a folder without metadata.yaml")
    try:
        with src.open("rb") as handle:
            head = handle.read(16)
    except OSError as err:
        raise RecordingError(f"cannot read {src}: {err.strerror}") from err
    if head.startswith(b"\x89MCAP"):
        return "mcap"
    if head.startswith(ROS1_MAGIC):
        return "ros1"
    if src.suffix == ".db3" and head.startswith(SQLITE_MAGIC):
        return "ros2"
    raise RecordingError(
        f"{src}: slt recover reads MCAP files, ROS 1 bags and ROS 2 bags (folder or .db3)"
    )


def _check_out(fmt: RecoverFormat, src: Path, out: Path) -> None:
    if out.exists():
        raise UsageError(f"{out} exists already; not overwriting a recording")
    if out.resolve() == src.resolve():
        raise UsageError("-o must differ from the input")
    suffix = {"mcap": ".mcap", "ros1": ".bag", "ros2": ""}[fmt]
    if out.suffix != suffix:
        raise UsageError(f"a recovered {_NAMES[fmt]} is written to {_OUT_FORM[fmt]}")


def recover(src: Path, out: Path) -> RecoverResult:
    """Write every readable message of ``src`` into ``out``, in the same format, atomically.

    MCAP files are scanned record by record (``recording.scan``); bags are read by the same
    sources ``slt cat`` uses (ROS 1 reindexed by scanning when its index is unusable, ROS 2
    sqlite3 files salvaged row by row) and copied with their connections.

    Raises:
        UsageError: For an existing or wrongly named ``out``.
        RecordingError: If nothing in ``src`` is readable, or ``out`` cannot be written.
    """
    fmt = input_format(src)
    _check_out(fmt, src, out)
    if fmt == "mcap":
        from superlane_tools.recording.recover import recover_mcap

        written, scan = recover_mcap(src, out)
        lost = tuple(
            {
                "what": loss.what,
                "detail": loss.detail,
                "messages": loss.n_messages,
                "start_ns": loss.start_ns,
                "stop_ns": loss.stop_ns,
                "topics": [part._asdict() for part in loss.topics],
            }
            for loss in scan.losses
        )
    else:
        from superlane_tools.recording.bag_filter import filter_bag

        try:
            written, skipped = filter_bag(src, out, lambda _topic: True, lambda _t: (None, None))
        except UsageError as err:  # no topic or no message: nothing was readable
            raise RecordingError(f"{src}: no readable message; nothing written") from err
        lost = tuple(
            {"what": s.what, "detail": s.detail, "messages": s.n_items or None} for s in skipped
        )
    if not written:
        out.unlink(missing_ok=True)
        raise RecordingError(f"{src}: no readable message; nothing written")
    return RecoverResult(src, out, fmt, written, lost)
