"""Write a simulated drive: camera, CAN and RTK into a recording, ground truth beside it.

Frames are streamed (world -> render -> JPEG -> writer) so memory stays flat; sensor messages
are merged in time order through a small heap. All randomness comes from the seed's named
streams (``world.rng_streams``), timestamps start at a fixed epoch, so the same arguments give
byte-identical files.
"""

from __future__ import annotations

import heapq
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from superlane_tools.camera.metadata import METADATA_NAME, camera_metadata, camera_quaternion_xyzw
from superlane_tools.camera.model import CameraModel
from superlane_tools.reporting import ParquetStreamWriter, Provenance, atomic_path
from superlane_tools.simulation.errors import ScenarioError, SimulationError
from superlane_tools.simulation.groundtruth import (
    GT_SCHEMA,
    gt_row,
    h_samples,
    lane_truth,
    tusimple_lanes,
)
from superlane_tools.simulation.scenarios import get_scenario
from superlane_tools.simulation.sensors import (
    MobileyeParams,
    RtkParams,
    VehicleOptions,
    heartbeat_can,
    imu_gyro,
    mobileye_can,
    rtk_fixes,
    vehicle_can,
)
from superlane_tools.simulation.world import build_world, frame_world, rng_streams

DEFAULT_START_NS = 1_700_000_000_000_000_000
"""Time of the first frame, ns since the epoch (2023-11-14T22:13:20Z); fixed for determinism."""
FORMATS = ("mcap", "ros1", "ros2")
MIN_SIZE, MAX_SIZE = 64, 4096

TOPIC_IMAGE = "/camera/image/compressed"
TOPIC_INFO = "/camera/camera_info"
TOPIC_TF = "/tf_static"
TOPIC_CAN = "/can/rx"
TOPIC_FIX = "/gnss/fix"
TOPIC_CAN2 = "/can1/rx"
"""The second CAN bus (Mobileye lanes and a camera heartbeat) with ``VehicleOptions.second_bus``."""
TOPIC_IMU = "/imu/data"
FRAME_VEHICLE = "base_link"
FRAME_CAMERA = "camera_optical"
FRAME_GNSS = "gnss"

ProgressFn = Callable[[int, int], None]


@dataclass(frozen=True)
class DriveOutputs:
    """Where a drive's files go.

    Attributes:
        recording: The recording (``.mcap``/``.bag`` file or ROS 2 bag folder).
        groundtruth: ``<stem>.gt.parquet``.
        tusimple: ``<stem>.tusimple.json`` (JSON lines).
        labels_dir: ``<stem>_labels/`` (``frames/``, ``labels/``, ``corridor/`` PNG/JPEG files).
    """

    recording: Path
    groundtruth: Path
    tusimple: Path
    labels_dir: Path

    @classmethod
    def beside(cls, recording: Path) -> DriveOutputs:
        """Return the output paths for a recording path."""
        stem = recording.name.split(".")[0] if recording.suffix else recording.name
        parent = recording.parent
        return cls(
            recording,
            parent / f"{stem}.gt.parquet",
            parent / f"{stem}.tusimple.json",
            parent / f"{stem}_labels",
        )


@dataclass(frozen=True)
class DriveResult:
    """What :func:`simulate_drive` wrote and how long each stage took.

    Attributes:
        outputs: The files written (``labels_dir`` only exists with labels).
        frames: Camera frames written.
        messages: Messages written in total.
        seconds: Wall time per stage: ``world``, ``render``, ``encode``, ``write`` (seconds).
    """

    outputs: DriveOutputs
    frames: int
    messages: int
    seconds: dict[str, float] = field(default_factory=dict)


def validate_size(width: int, height: int) -> None:
    """Raise :class:`ScenarioError` unless the image size is possible (64-4096 px, not tall)."""
    if not (MIN_SIZE <= width <= MAX_SIZE and MIN_SIZE <= height <= MAX_SIZE):
        raise ScenarioError(f"image size must be {MIN_SIZE}-{MAX_SIZE} px, got {width}x{height}")
    if height > width:
        raise ScenarioError(f"image must be landscape (width >= height), got {width}x{height}")


def sim_camera(width: int, height: int) -> CameraModel:
    """Return the ``sim_default`` camera resized to ``width x height`` pixels."""
    from superlane_tools.camera.profiles import load_camera

    validate_size(width, height)
    return load_camera("sim_default").resized(width, height)


def encode_jpeg(image_bgr: Any, quality: int) -> bytes:
    """Encode a BGR image as baseline JPEG (deterministic for the same input)."""
    import cv2

    ok, buf = cv2.imencode(".jpg", image_bgr, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise SimulationError("JPEG encoding failed")
    return bytes(buf)


def encode_png(image: Any) -> bytes:
    """Encode a single-channel image as PNG."""
    import cv2

    ok, buf = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 3])
    if not ok:
        raise SimulationError("PNG encoding failed")
    return bytes(buf)


def simulate_drive(
    scenario: str,
    duration_s: float,
    seed: int,
    fmt: str,
    width: int,
    height: int,
    labels: bool,
    out: str | Path,
    *,
    fps: float = 15.0,
    jpeg_quality: int | None = None,
    video: str | None = None,
    rtk: RtkParams | None = None,
    vehicle: VehicleOptions | None = None,
    start_ns: int = DEFAULT_START_NS,
    command: str = "",
    progress: ProgressFn | None = None,
    camera_roll_rad: float = 0.0,
) -> DriveResult:
    """Simulate a drive and write the recording plus its ground truth.

    Args:
        scenario: Scenario name (see ``scenarios.SCENARIOS``).
        duration_s: Length of the drive, seconds.
        seed: Seed of every random choice.
        fmt: ``mcap`` (ROS 2 CDR), ``ros1`` (.bag) or ``ros2`` (bag folder).
        width: Image width, pixels.
        height: Image height, pixels.
        labels: Also write per-frame JPEG, leaf-id label PNG and corridor PNG files.
        out: Recording path; ground truth goes beside it (:class:`DriveOutputs`).
        fps: Camera frame rate, Hz.
        jpeg_quality: JPEG quality override (default: the scenario's conditions).
        video: ``h264`` or ``h265``: write the camera as ``foxglove_msgs/msg/CompressedVideo``
            (one access unit per frame, a keyframe every second) instead of JPEG images.
        rtk: GNSS simulation parameters (default RTK fixed at 10 Hz).
        vehicle: Speed unit, IMU topic and second CAN bus (default: m/s, no IMU, one bus).
        start_ns: Time of the first frame, ns since the epoch.
        command: Command line for the provenance metadata.
        progress: Called as ``progress(done, total)`` after each frame.
        camera_roll_rad: Roll of the camera about its optical axis (left side up positive),
            radians; the recording's camera metadata carries it.

    Raises:
        ScenarioError: For an unknown scenario or impossible sizes/durations/formats.
        SimulationError: If the renderer or an encoder fails.
        RecordingError: If the recording cannot be written (e.g. it exists).
    """
    from superlane_tools.recording import messages as msgs
    from superlane_tools.recording import open_writer

    spec = get_scenario(scenario)
    if fmt not in FORMATS:
        raise ScenarioError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if not 1.0 <= fps <= 60.0:
        raise ScenarioError(f"frame rate must be 1-60 Hz, got {fps}")
    if jpeg_quality is not None and not 1 <= jpeg_quality <= 100:
        raise ScenarioError(f"JPEG quality must be 1-100, got {jpeg_quality}")
    if abs(camera_roll_rad) > 0.2:
        raise ScenarioError(f"camera roll must be within 0.2 rad, got {camera_roll_rad}")
    camera = sim_camera(width, height)
    if camera_roll_rad:
        camera = replace(camera, extrinsics=replace(camera.extrinsics, roll_rad=camera_roll_rad))
    encoder = None
    if video is not None:
        from superlane_tools.recording.errors import RecordingError
        from superlane_tools.recording.video import VideoEncoder

        try:
            encoder = VideoEncoder(video, width, height, fps, gop=max(1, round(fps)))
        except RecordingError as err:
            raise ScenarioError(str(err)) from err
    rtk = rtk or RtkParams()
    rtk.validate()
    outputs = DriveOutputs.beside(Path(out))
    world = build_world(spec, seed, duration_s)
    from superlane_tools.simulation.render import render

    rng = rng_streams(seed)
    n_frames = max(1, round(duration_s * fps))
    frame_seeds = rng["render"].integers(0, 2**31, n_frames)
    quality = jpeg_quality if jpeg_quality is not None else spec.conditions.jpeg_quality
    vehicle = vehicle or VehicleOptions()
    me_params = MobileyeParams(quality=spec.lane_quality, latency_s=vehicle.mobileye_latency_s)
    rows = h_samples(height)

    # timed non-camera events: (t_ns, seq, topic, message factory args)
    events: list[tuple[int, int, str, tuple[Any, ...]]] = []
    seq = 0

    def push(t_ns: int, topic: str, payload: tuple[Any, ...]) -> None:
        nonlocal seq
        heapq.heappush(events, (t_ns, seq, topic, payload))
        seq += 1

    q = camera_quaternion_xyzw(camera)
    pos = camera.extrinsics.position
    push(start_ns, TOPIC_TF, ("tf", tuple(float(v) for v in pos), q))
    for c in vehicle_can(world, start_ns, rng["sensors"], speed_kph=vehicle.speed_kph):
        push(c.log_time_ns, TOPIC_CAN, ("can", c.can_id, c.data))
    if vehicle.second_bus:
        for c in heartbeat_can(world, start_ns):
            push(c.log_time_ns, TOPIC_CAN2, ("can", c.can_id, c.data))
    if vehicle.imu:  # its own generator: the other sensors' draws stay the same
        import numpy as np

        imu_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(64)[-1])
        for t_imu, gyro in imu_gyro(world, start_ns, imu_rng):
            push(t_imu, TOPIC_IMU, ("imu", gyro))
    for f in rtk_fixes(world, rtk, start_ns, rng["sensors"]):
        push(f.log_time_ns, TOPIC_FIX, ("fix", f))

    def build(item: tuple[str, tuple[Any, ...]], t_ns: int) -> Any:
        kind = item[1][0]
        if kind == "tf":
            return msgs.tf_static(t_ns, FRAME_VEHICLE, FRAME_CAMERA, item[1][1], item[1][2])
        if kind == "can":
            return msgs.can_frame(t_ns, item[1][1], item[1][2])
        if kind == "imu":
            return msgs.imu(t_ns, FRAME_VEHICLE, item[1][1])
        fix = item[1][1]
        return msgs.navsatfix(
            t_ns, FRAME_GNSS, fix.lat_deg, fix.lon_deg, fix.alt_m, fix.status, fix.covariance_enu_m2
        )

    k = camera.intrinsics
    provenance = Provenance(
        command=command or f"simulate_drive({scenario!r}, seed={seed})",
        config={
            "scenario": scenario,
            "duration_s": duration_s,
            "seed": seed,
            "format": fmt,
            "width": width,
            "height": height,
            "fps": fps,
            "jpeg_quality": quality,
            "video": video,
            "start_ns": start_ns,
            "rtk": asdict(rtk),
            "vehicle": asdict(vehicle),
            "camera": camera.to_dict(),
            "recording": outputs.recording.name,
        },
    )
    seconds = {"world": 0.0, "render": 0.0, "encode": 0.0, "write": 0.0}
    written = 0
    writer_fmt = "mcap" if fmt == "mcap" else fmt
    if labels:
        for sub in ("frames", "labels", "corridor"):
            (outputs.labels_dir / sub).mkdir(parents=True, exist_ok=True)
    batch: list[dict[str, object]] = []
    with (
        open_writer(outputs.recording, writer_fmt) as writer,  # type: ignore[arg-type]
        ParquetStreamWriter(outputs.groundtruth, GT_SCHEMA, provenance) as gt_writer,
        atomic_path(outputs.tusimple) as tus_tmp,
        tus_tmp.open("w", encoding="utf-8") as tus,
    ):
        for topic, msgtype in (
            (TOPIC_TF, "tf2_msgs/msg/TFMessage"),
            (TOPIC_INFO, "sensor_msgs/msg/CameraInfo"),
            (
                TOPIC_IMAGE,
                "sensor_msgs/msg/CompressedImage"
                if encoder is None
                else "foxglove_msgs/msg/CompressedVideo",
            ),
            (TOPIC_CAN, "can_msgs/msg/Frame"),
            (TOPIC_FIX, "sensor_msgs/msg/NavSatFix"),
            *([(TOPIC_CAN2, "can_msgs/msg/Frame")] if vehicle.second_bus else []),
            *([(TOPIC_IMU, "sensor_msgs/msg/Imu")] if vehicle.imu else []),
        ):
            writer.add_topic(topic, msgtype)
        add_metadata = getattr(writer, "add_metadata", None)
        if fmt == "mcap" and add_metadata is not None:
            add_metadata(METADATA_NAME, camera_metadata(camera, FRAME_VEHICLE, FRAME_CAMERA))
        for i in range(n_frames):
            t_s = i / fps
            t_ns = start_ns + round(i * 1e9 / fps)
            t0 = time.perf_counter()
            fw = frame_world(world, t_s, t_ns, camera, int(frame_seeds[i]))
            truth = lane_truth(fw)
            me_topic = TOPIC_CAN2 if vehicle.second_bus else TOPIC_CAN
            for c in mobileye_can(truth, t_ns, me_params, rng["sensors"]):
                push(c.log_time_ns, me_topic, ("can", c.can_id, c.data))
            t1 = time.perf_counter()
            try:
                frame = render(fw.scene)
            except Exception as err:  # the renderer is a separate stage; report it as such
                raise SimulationError(f"renderer failed on frame {i}: {err}") from err
            t2 = time.perf_counter()
            jpeg = encode_jpeg(frame.image_bgr, quality)
            lanes = tusimple_lanes(
                fw.scene.road, camera, truth.profile_index, rows, labels=frame.labels
            )
            t3 = time.perf_counter()
            while events and events[0][0] <= t_ns:
                ev_t, _, topic, payload = heapq.heappop(events)
                writer.write(topic, ev_t, build((topic, payload), ev_t))
                written += 1
            writer.write(
                TOPIC_INFO,
                t_ns,
                msgs.camera_info(t_ns, FRAME_CAMERA, k.width, k.height, k.matrix, list(k.dist)),
            )
            writer.write(
                TOPIC_IMAGE,
                t_ns,
                msgs.compressed_image(t_ns, FRAME_CAMERA, "jpeg", jpeg)
                if encoder is None
                else msgs.compressed_video(
                    t_ns, FRAME_CAMERA, encoder.fmt, encoder.encode(frame.image_bgr)
                ),
            )
            written += 2
            name = f"{i:06d}"
            tus.write(
                json.dumps(
                    {
                        "raw_file": f"frames/{name}.jpg",
                        "lanes": lanes,
                        "h_samples": rows,
                        "color": list(truth.colors),
                        "style": list(truth.styles),
                    },
                    separators=(",", ":"),
                )
                + "\n"
            )
            batch.append(gt_row(fw, truth, i))
            if len(batch) >= 64:
                gt_writer.write({key: [r[key] for r in batch] for key in GT_SCHEMA.names})
                batch.clear()
            if labels:
                (outputs.labels_dir / "frames" / f"{name}.jpg").write_bytes(jpeg)
                (outputs.labels_dir / "labels" / f"{name}.png").write_bytes(
                    encode_png(frame.labels)
                )
                (outputs.labels_dir / "corridor" / f"{name}.png").write_bytes(
                    encode_png(frame.corridor.astype("uint8") * 255)
                )
            t4 = time.perf_counter()
            seconds["world"] += t1 - t0
            seconds["render"] += t2 - t1
            seconds["encode"] += t3 - t2
            seconds["write"] += t4 - t3
            if progress is not None:
                progress(i + 1, n_frames)
        end_ns = start_ns + round(duration_s * 1e9)
        while events and events[0][0] <= end_ns:
            ev_t, _, topic, payload = heapq.heappop(events)
            writer.write(topic, ev_t, build((topic, payload), ev_t))
            written += 1
        if batch:
            gt_writer.write({key: [r[key] for r in batch] for key in GT_SCHEMA.names})
    return DriveResult(outputs, n_frames, written, seconds)
