"""Fixtures for recording tests: small drives written with the project's own writers."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from superlane_tools.recording import messages as m
from superlane_tools.recording.writers import open_writer

T0_NS = 1_700_000_000_000_000_000
STEP_NS = 100_000_000
N_STEPS = 40
TOPICS = {
    "/gnss/fix": "sensor_msgs/msg/NavSatFix",
    "/can/raw": "can_msgs/msg/Frame",
    "/camera/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/camera/camera_info": "sensor_msgs/msg/CameraInfo",
    "/camera/image_raw": "sensor_msgs/msg/Image",
    "/tf_static": "tf2_msgs/msg/TFMessage",
}
# messages per topic written by write_drive
EXPECTED_COUNTS = {
    "/gnss/fix": N_STEPS,
    "/can/raw": N_STEPS,
    "/camera/image/compressed": N_STEPS,
    "/camera/camera_info": N_STEPS // 10,
    "/camera/image_raw": N_STEPS // 10,
    "/tf_static": 1,
}
STAMP_LAG_NS = 5_000_000  # GNSS header stamps lead log time by 5 ms


def write_drive(path: Path, fmt: str, storage: str = "sqlite3", chunk_size: int = 1 << 20) -> Path:
    """Write a small deterministic drive with every message kind the project uses."""
    with open_writer(path, fmt, ros2_storage=storage, chunk_size=chunk_size) as w:  # type: ignore[arg-type]
        for topic, msgtype in TOPICS.items():
            w.add_topic(topic, msgtype)
        w.write(
            "/tf_static",
            T0_NS,
            m.tf_static(T0_NS, "base_link", "camera", (1.2, 0, 1.4), (0, 0, 0, 1)),
        )
        for i in range(N_STEPS):
            t = T0_NS + i * STEP_NS
            w.write(
                "/gnss/fix",
                t + 1,
                m.navsatfix(
                    t - STAMP_LAG_NS, "gnss", 48.1 + i * 1e-6, 11.5, 520.0, 2, np.eye(3) * 0.04
                ),
            )
            w.write(
                "/can/raw", t + 2, m.can_frame(t, 0x415, bytes([i, 1, 2, 3, 4]), is_extended=False)
            )
            w.write(
                "/camera/image/compressed",
                t + 3,
                m.compressed_image(t, "camera", "jpeg", b"\xff\xd8" + bytes([i]) * 500),
            )
            if i % 10 == 0:
                k = [[910.0, 0, 582], [0, 910.0, 437], [0, 0, 1]]
                w.write(
                    "/camera/camera_info",
                    t + 4,
                    m.camera_info(t, "camera", 1164, 874, k, [0.1, 0, 0, 0, 0]),
                )
                w.write(
                    "/camera/image_raw",
                    t + 5,
                    m.raw_image(t, "camera", np.full((6, 8), i, np.uint8), "mono8"),
                )
    return path


@pytest.fixture
def drive(tmp_path: Path) -> SimpleNamespace:
    """The drive's constants plus ``write(name, fmt, storage, chunk_size)`` into tmp_path."""

    def write(name: str, fmt: str, storage: str = "sqlite3", chunk_size: int = 1 << 20) -> Path:
        return write_drive(tmp_path / name, fmt, storage, chunk_size)

    return SimpleNamespace(
        write=write,
        write_to=write_drive,
        t0_ns=T0_NS,
        step_ns=STEP_NS,
        n_steps=N_STEPS,
        topics=TOPICS,
        counts=EXPECTED_COUNTS,
        total=sum(EXPECTED_COUNTS.values()),
        stamp_lag_ns=STAMP_LAG_NS,
    )
