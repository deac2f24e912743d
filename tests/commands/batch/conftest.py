"""Fixtures for the batch tests: small real recordings written with the project's writers."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from superlane_tools.recording.messages import can_frame, compressed_image, navsatfix
from superlane_tools.recording.writers import open_writer

T0 = 1_700_000_000_000_000_000
MS = 1_000_000
FRAMES = 10

MakeRecording = Callable[..., Path]


def _write_drive(path: Path, seed: int = 0, frames: int = FRAMES, fmt: str = "mcap") -> Path:
    """Write a drive: 10 Hz JPEG frames (64x48), CAN and RTK fixes, one of each per frame."""
    rng = np.random.default_rng(seed)
    with open_writer(path, fmt) as w:  # type: ignore[arg-type]
        w.add_topic("/cam/compressed", "sensor_msgs/msg/CompressedImage")
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(frames):
            t = T0 + seed * 1_000_000_000_000 + i * 100 * MS
            img = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
            jpeg = cv2.imencode(".jpg", img)[1].tobytes()
            w.write("/cam/compressed", t, compressed_image(t, "cam", "jpeg", jpeg))
            w.write("/can", t, can_frame(t, 256, bytes([i % 256, seed % 256])))
            w.write("/fix", t, navsatfix(t, "gps", 48.0 + i * 1e-5, 11.0, 500.0, status=2))
    return path


def _write_corrupt(path: Path, how: str) -> Path:
    """Write a broken recording: ``garbage`` bytes, or a ``truncated`` MCAP (magic only)."""
    if how == "garbage":
        path.write_bytes(b"this is not a recording\n" * 10)
    else:
        path.write_bytes(b"\x89MCAP0\r\n\x01\x02")
    return path


@pytest.fixture
def make_drives(tmp_path: Path) -> Callable[[int, int], list[Path]]:
    """Return ``make(n_good, n_corrupt)`` writing drives into ``tmp_path/recs``."""

    def make(n_good: int, n_corrupt: int = 0, folder: str = "recs") -> list[Path]:
        out = tmp_path / folder
        out.mkdir(parents=True, exist_ok=True)
        paths = [_write_drive(out / f"drive_{k:02d}.mcap", seed=k) for k in range(n_good)]
        for k in range(n_corrupt):
            how = "garbage" if k % 2 == 0 else "truncated"
            paths.append(_write_corrupt(out / f"corrupt_{k}.mcap", how))
        return paths

    return make


@pytest.fixture
def write_drive() -> Callable[..., Path]:
    """Return the drive writer ``write_drive(path, seed=0, frames=10, fmt="mcap")``."""
    return _write_drive


@pytest.fixture
def write_corrupt() -> Callable[[Path, str], Path]:
    """Return the broken-recording writer ``write_corrupt(path, "garbage"|"truncated")``."""
    return _write_corrupt
