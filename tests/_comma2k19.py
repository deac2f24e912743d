"""Pack the real comma2k19 minute into an MCAP recording (a test and script helper).

Raw CAN of buses 0 and 1 on ``/can0`` and ``/can1`` (``can_msgs/msg/Frame``), the u-blox fixes
on ``/gnss/fix`` (``sensor_msgs/msg/NavSatFix``, plain GNSS: status 0, covariance unknown) and
the calibrated gyro on ``/imu`` (``sensor_msgs/msg/Imu`` in the phone's sensor frame, where
the vertical axis is ``-z``). Log times are comma's monotonic seconds in nanoseconds. Nothing
is committed: the recording is built from ``$SLT_REALDATA/comma2k19/segment`` on demand.

Usage: ``python tests/_comma2k19.py OUT.mcap``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np

from superlane_tools.recording.messages import can_frame, imu, navsatfix
from superlane_tools.recording.writers import open_writer

BUS_TOPICS = {0: "/can0", 1: "/can1"}


class FusedTrack(NamedTuple):
    """comma's fused trajectory: times (ns, same clock as the recording) and ECEF metres."""

    t_ns: np.ndarray
    ecef_m: np.ndarray


def segment(realdata: Path) -> Path:
    """Return the comma2k19 segment folder."""
    return realdata / "comma2k19" / "segment"


def fused_track(realdata: Path) -> FusedTrack:
    """Return ``global_pose/frame_times`` (as ns) and ``frame_positions`` (ECEF, m)."""
    root = segment(realdata) / "global_pose"
    t = np.load(root / "frame_times")
    return FusedTrack((t * 1e9).round().astype(np.int64), np.load(root / "frame_positions"))


def pack(realdata: Path, out: Path) -> Path:
    """Write the recording to ``out`` (MCAP, ROS 2 CDR) and return its path."""
    root = segment(realdata) / "processed_log"
    can = root / "CAN" / "raw_can"
    t_can = (np.load(can / "t") * 1e9).round().astype(np.int64)
    address = np.load(can / "address").astype(np.int64)
    data = np.load(can / "data").view(np.uint8).reshape(-1, 8)
    src = np.load(can / "src").astype(np.int64)
    gnss = np.load(root / "GNSS" / "live_gnss_ublox" / "value")
    t_gnss = (np.load(root / "GNSS" / "live_gnss_ublox" / "t") * 1e9).round().astype(np.int64)
    gyro = np.load(root / "IMU" / "gyro" / "value")
    t_gyro = (np.load(root / "IMU" / "gyro" / "t") * 1e9).round().astype(np.int64)
    events: list[tuple[int, int, int]] = []  # (time, kind, index) kinds: 0 CAN, 1 GNSS, 2 IMU
    events += [(int(t), 0, i) for i, t in enumerate(t_can) if int(src[i]) in BUS_TOPICS]
    events += [(int(t), 1, i) for i, t in enumerate(t_gnss)]
    events += [(int(t), 2, i) for i, t in enumerate(t_gyro)]
    events.sort()
    with open_writer(out, "mcap") as writer:
        for topic in BUS_TOPICS.values():
            writer.add_topic(topic, "can_msgs/msg/Frame")
        writer.add_topic("/gnss/fix", "sensor_msgs/msg/NavSatFix")
        writer.add_topic("/imu", "sensor_msgs/msg/Imu")
        for t, kind, i in events:
            if kind == 0:
                msg = can_frame(t, int(address[i]), data[i].tobytes())
                writer.write(BUS_TOPICS[int(src[i])], t, msg)
            elif kind == 1:
                lat, lon, alt = (float(v) for v in gnss[i, :3])
                writer.write("/gnss/fix", t, navsatfix(t, "gnss", lat, lon, alt, status=0))
            else:
                writer.write("/imu", t, imu(t, "imu", gyro[i]))
    return out


if __name__ == "__main__":
    import os

    data_root = Path(os.environ.get("SLT_REALDATA", "../shared/data"))
    print(pack(data_root, Path(sys.argv[1])))
