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

import numpy as np
from numpy.typing import NDArray

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
from superlane_tools.simulation.scenarios import Scenario, get_scenario
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
from superlane_tools.simulation.world import World, build_world, frame_world, rng_streams

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
    spec = get_scenario(scenario)
    _check_options(fmt, fps, jpeg_quality, camera_roll_rad)
    request = _DriveRequest(
        scenario,
        duration_s,
        seed,
        fmt,
        width,
        height,
        fps,
        jpeg_quality if jpeg_quality is not None else spec.conditions.jpeg_quality,
        video,
        start_ns,
        rtk or RtkParams(),
        vehicle or VehicleOptions(),
        camera_roll_rad,
    )
    plan = _plan_drive(spec, request)
    outputs = DriveOutputs.beside(Path(out))
    provenance = Provenance(
        command=command or f"simulate_drive({scenario!r}, seed={seed})",
        config=request.config(plan.camera, outputs.recording.name),
    )
    frames = _write_drive(plan, outputs, labels, provenance, progress)
    return DriveResult(outputs, plan.n_frames, frames.written, frames.seconds)


@dataclass(frozen=True)
class _DriveRequest:
    """The options of one :func:`simulate_drive` call, defaults filled in (see its arguments).

    ``quality`` is the JPEG quality used (the override or the scenario's).
    """

    scenario: str
    duration_s: float
    seed: int
    fmt: str
    width: int
    height: int
    fps: float
    quality: int
    video: str | None
    start_ns: int
    rtk: RtkParams
    vehicle: VehicleOptions
    camera_roll_rad: float

    def config(self, camera: CameraModel, recording: str) -> dict[str, Any]:
        """Return the provenance config: every option, the camera and the recording's name."""
        return {
            "scenario": self.scenario,
            "duration_s": self.duration_s,
            "seed": self.seed,
            "format": self.fmt,
            "width": self.width,
            "height": self.height,
            "fps": self.fps,
            "jpeg_quality": self.quality,
            "video": self.video,
            "start_ns": self.start_ns,
            "rtk": asdict(self.rtk),
            "vehicle": asdict(self.vehicle),
            "camera": camera.to_dict(),
            "recording": recording,
        }


@dataclass(frozen=True)
class _DrivePlan:
    """A checked drive before anything is written: world, camera, frame seeds, sensor messages.

    Attributes:
        request: The options.
        world: The scenario's world.
        camera: The camera (with its roll).
        encoder: The video encoder, None for JPEG images.
        lane_quality: The scenario's nominal Mobileye lane quality 0-3.
        frame_seeds: Render seed of each frame.
        events: The queued transform, vehicle CAN, IMU and GNSS messages (more are pushed).
        sensor_rng: The sensors' random stream (the Mobileye messages draw from it per frame).
    """

    request: _DriveRequest
    world: World
    camera: CameraModel
    encoder: Any
    lane_quality: int
    frame_seeds: NDArray[np.int64]
    events: _SensorEvents
    sensor_rng: np.random.Generator

    @property
    def n_frames(self) -> int:
        """Number of camera frames."""
        return len(self.frame_seeds)


def _plan_drive(spec: Scenario, request: _DriveRequest) -> _DrivePlan:
    """Check the size, video and GNSS options, build the world and queue the sensor messages.

    Raises:
        ScenarioError: For an impossible image size, video format or GNSS option.
    """
    r = request
    camera = sim_camera(r.width, r.height)
    if r.camera_roll_rad:
        camera = replace(camera, extrinsics=replace(camera.extrinsics, roll_rad=r.camera_roll_rad))
    encoder = _video_encoder(r.video, r.width, r.height, r.fps)
    r.rtk.validate()
    world = build_world(spec, r.seed, r.duration_s)
    rng = rng_streams(r.seed)
    n_frames = max(1, round(r.duration_s * r.fps))
    frame_seeds = rng["render"].integers(0, 2**31, n_frames)
    events = _SensorEvents()
    _schedule_sensors(events, world, camera, r.vehicle, r.rtk, r.start_ns, rng["sensors"], r.seed)
    return _DrivePlan(
        r, world, camera, encoder, spec.lane_quality, frame_seeds, events, rng["sensors"]
    )


def _write_drive(
    plan: _DrivePlan,
    outputs: DriveOutputs,
    labels: bool,
    provenance: Provenance,
    progress: ProgressFn | None,
) -> _FrameWriter:
    """Write the recording, ground truth, TuSimple lines and labels, frame by frame.

    Returns:
        The frame writer, with the messages written and the seconds per stage.
    """
    from superlane_tools.recording import open_writer

    r, camera, events = plan.request, plan.camera, plan.events
    if labels:
        for sub in ("frames", "labels", "corridor"):
            (outputs.labels_dir / sub).mkdir(parents=True, exist_ok=True)
    with (
        open_writer(outputs.recording, r.fmt) as writer,  # type: ignore[arg-type]
        ParquetStreamWriter(outputs.groundtruth, GT_SCHEMA, provenance) as gt_writer,
        atomic_path(outputs.tusimple) as tus_tmp,
        tus_tmp.open("w", encoding="utf-8") as tus,
    ):
        _add_topics(writer, r.fmt, camera, plan.encoder is not None, r.vehicle)
        frames = _FrameWriter(
            writer,
            gt_writer,
            tus,
            events,
            camera,
            plan.encoder,
            r.quality,
            outputs.labels_dir if labels else None,
            h_samples(r.height),
        )
        me_params = MobileyeParams(
            quality=plan.lane_quality, latency_s=r.vehicle.mobileye_latency_s
        )
        me_topic = TOPIC_CAN2 if r.vehicle.second_bus else TOPIC_CAN
        for i in range(plan.n_frames):
            t_ns = r.start_ns + round(i * 1e9 / r.fps)
            t0 = time.perf_counter()
            fw = frame_world(plan.world, i / r.fps, t_ns, camera, int(plan.frame_seeds[i]))
            truth = lane_truth(fw)
            for c in mobileye_can(truth, t_ns, me_params, plan.sensor_rng):
                events.push(c.log_time_ns, me_topic, ("can", c.can_id, c.data))
            frames.seconds["world"] += time.perf_counter() - t0
            frames.add(i, t_ns, fw, truth)
            if progress is not None:
                progress(i + 1, plan.n_frames)
        frames.written += events.write_until(writer, r.start_ns + round(r.duration_s * 1e9))
        frames.flush()
    return frames


def _check_options(fmt: str, fps: float, jpeg_quality: int | None, roll_rad: float) -> None:
    """Raise :class:`ScenarioError` for a format, frame rate, quality or roll out of range."""
    if fmt not in FORMATS:
        raise ScenarioError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if not 1.0 <= fps <= 60.0:
        raise ScenarioError(f"frame rate must be 1-60 Hz, got {fps}")
    if jpeg_quality is not None and not 1 <= jpeg_quality <= 100:
        raise ScenarioError(f"JPEG quality must be 1-100, got {jpeg_quality}")
    if abs(roll_rad) > 0.2:
        raise ScenarioError(f"camera roll must be within 0.2 rad, got {roll_rad}")


def _video_encoder(video: str | None, width: int, height: int, fps: float) -> Any:
    """The camera's video encoder (one keyframe a second), None for JPEG images."""
    if video is None:
        return None
    from superlane_tools.recording.errors import RecordingError
    from superlane_tools.recording.video import VideoEncoder

    try:
        return VideoEncoder(video, width, height, fps, gop=max(1, round(fps)))
    except RecordingError as err:
        raise ScenarioError(str(err)) from err


class _SensorEvents:
    """Timed non-camera messages, merged into the recording in time order through a heap."""

    def __init__(self) -> None:
        self._heap: list[tuple[int, int, str, tuple[Any, ...]]] = []
        self._seq = 0

    def push(self, t_ns: int, topic: str, payload: tuple[Any, ...]) -> None:
        """Queue one message: ``payload`` is ``(kind, *arguments)`` (see :meth:`_message`)."""
        heapq.heappush(self._heap, (t_ns, self._seq, topic, payload))
        self._seq += 1

    def write_until(self, writer: Any, t_ns: int) -> int:
        """Write the queued messages up to ``t_ns`` (inclusive); return how many."""
        n = 0
        while self._heap and self._heap[0][0] <= t_ns:
            ev_t, _, topic, payload = heapq.heappop(self._heap)
            writer.write(topic, ev_t, self._message(payload, ev_t))
            n += 1
        return n

    @staticmethod
    def _message(payload: tuple[Any, ...], t_ns: int) -> Any:
        from superlane_tools.recording import messages as msgs

        kind = payload[0]
        if kind == "tf":
            return msgs.tf_static(t_ns, FRAME_VEHICLE, FRAME_CAMERA, payload[1], payload[2])
        if kind == "can":
            return msgs.can_frame(t_ns, payload[1], payload[2])
        if kind == "imu":
            return msgs.imu(t_ns, FRAME_VEHICLE, payload[1])
        fix = payload[1]
        return msgs.navsatfix(
            t_ns, FRAME_GNSS, fix.lat_deg, fix.lon_deg, fix.alt_m, fix.status, fix.covariance_enu_m2
        )


def _schedule_sensors(
    events: _SensorEvents,
    world: Any,
    camera: CameraModel,
    vehicle: VehicleOptions,
    rtk: RtkParams,
    start_ns: int,
    rng: Any,
    seed: int,
) -> None:
    """Queue the camera transform, the vehicle CAN, the IMU and the GNSS fixes of the drive."""
    q = camera_quaternion_xyzw(camera)
    pos = camera.extrinsics.position
    events.push(start_ns, TOPIC_TF, ("tf", tuple(float(v) for v in pos), q))
    for c in vehicle_can(world, start_ns, rng, speed_kph=vehicle.speed_kph):
        events.push(c.log_time_ns, TOPIC_CAN, ("can", c.can_id, c.data))
    if vehicle.second_bus:
        for c in heartbeat_can(world, start_ns):
            events.push(c.log_time_ns, TOPIC_CAN2, ("can", c.can_id, c.data))
    if vehicle.imu:  # its own generator: the other sensors' draws stay the same
        imu_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(64)[-1])
        for t_imu, gyro in imu_gyro(world, start_ns, imu_rng):
            events.push(t_imu, TOPIC_IMU, ("imu", gyro))
    for f in rtk_fixes(world, rtk, start_ns, rng):
        events.push(f.log_time_ns, TOPIC_FIX, ("fix", f))


def _add_topics(
    writer: Any, fmt: str, camera: CameraModel, video: bool, vehicle: VehicleOptions
) -> None:
    """Declare the recording's topics (and, in MCAP, the camera metadata record)."""
    for topic, msgtype in (
        (TOPIC_TF, "tf2_msgs/msg/TFMessage"),
        (TOPIC_INFO, "sensor_msgs/msg/CameraInfo"),
        (
            TOPIC_IMAGE,
            "foxglove_msgs/msg/CompressedVideo" if video else "sensor_msgs/msg/CompressedImage",
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


@dataclass
class _FrameWriter:
    """Renders one frame and writes it everywhere: recording, ground truth, TuSimple, labels."""

    writer: Any
    gt_writer: ParquetStreamWriter
    tus: Any
    events: _SensorEvents
    camera: CameraModel
    encoder: Any
    quality: int
    labels_dir: Path | None
    rows: list[int]
    written: int = 0
    seconds: dict[str, float] = field(
        default_factory=lambda: {"world": 0.0, "render": 0.0, "encode": 0.0, "write": 0.0}
    )
    batch: list[dict[str, object]] = field(default_factory=list)

    def add(self, i: int, t_ns: int, fw: Any, truth: Any) -> None:
        """Render frame ``i`` of the world ``fw`` and write it with the messages before it."""
        from superlane_tools.recording import messages as msgs
        from superlane_tools.simulation.render import render

        t1 = time.perf_counter()
        try:
            frame = render(fw.scene)
        except Exception as err:  # the renderer is a separate stage; report it as such
            raise SimulationError(f"renderer failed on frame {i}: {err}") from err
        t2 = time.perf_counter()
        jpeg = encode_jpeg(frame.image_bgr, self.quality)
        lanes = tusimple_lanes(
            fw.scene.road, self.camera, truth.profile_index, self.rows, labels=frame.labels
        )
        t3 = time.perf_counter()
        self.written += self.events.write_until(self.writer, t_ns)
        k = self.camera.intrinsics
        self.writer.write(
            TOPIC_INFO,
            t_ns,
            msgs.camera_info(t_ns, FRAME_CAMERA, k.width, k.height, k.matrix, list(k.dist)),
        )
        self.writer.write(
            TOPIC_IMAGE,
            t_ns,
            msgs.compressed_image(t_ns, FRAME_CAMERA, "jpeg", jpeg)
            if self.encoder is None
            else msgs.compressed_video(
                t_ns, FRAME_CAMERA, self.encoder.fmt, self.encoder.encode(frame.image_bgr)
            ),
        )
        self.written += 2
        name = f"{i:06d}"
        self.tus.write(
            json.dumps(
                {
                    "raw_file": f"frames/{name}.jpg",
                    "lanes": lanes,
                    "h_samples": self.rows,
                    "color": list(truth.colors),
                    "style": list(truth.styles),
                },
                separators=(",", ":"),
            )
            + "\n"
        )
        self.batch.append(gt_row(fw, truth, i))
        if len(self.batch) >= 64:
            self.flush()
        if self.labels_dir is not None:
            (self.labels_dir / "frames" / f"{name}.jpg").write_bytes(jpeg)
            (self.labels_dir / "labels" / f"{name}.png").write_bytes(encode_png(frame.labels))
            (self.labels_dir / "corridor" / f"{name}.png").write_bytes(
                encode_png(frame.corridor.astype("uint8") * 255)
            )
        t4 = time.perf_counter()
        self.seconds["render"] += t2 - t1
        self.seconds["encode"] += t3 - t2
        self.seconds["write"] += t4 - t3

    def flush(self) -> None:
        """Write the batched ground-truth rows."""
        if self.batch:
            self.gt_writer.write({key: [r[key] for r in self.batch] for key in GT_SCHEMA.names})
            self.batch.clear()
