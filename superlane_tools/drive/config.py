"""Configuration of ``slt reprocess``: frozen sections loadable from TOML or YAML, with defaults."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from superlane_tools.corridor import AvailabilityParams, TimeSegment
from superlane_tools.errors import ConfigError
from superlane_tools.lanes.tracker import TrackerParams

if TYPE_CHECKING:
    from superlane_tools.lanes import FitParams

BACKENDS = ("auto", "classical", "onnx", "oracle")
DEFAULT_FIT: Mapping[str, Any] = {"max_range_m": 60.0}
"""Reprocess's overrides of the lane fit's defaults: points up to 60 m ahead only, the range of
the lane-model ground truth (5-60 m). Farther points add vertical-curvature error on hills and
move the curvature the quadratic describes farther ahead (see docs/reprocess.md)."""


@dataclass(frozen=True)
class TopicsConfig:
    """Topics per stream; empty strings are auto-detected by message type.

    Attributes:
        frames: Camera image topic (``sensor_msgs/msg/(Compressed)Image``, Foxglove images).
        camera_info: Camera calibration topic.
        can: CAN frame topic (``can_msgs/msg/Frame``).
        gnss: GNSS fix topic (``sensor_msgs/msg/NavSatFix``).
        imu: IMU topic (``sensor_msgs/msg/Imu``) for the yaw-rate curvature reference.
    """

    frames: str = ""
    camera_info: str = ""
    can: str = ""
    gnss: str = ""
    imu: str = ""


@dataclass(frozen=True)
class SegmentationConfig:
    """Which segmentation feeds the SUPER lane fit.

    Attributes:
        backend: ``auto`` (the per-drive self-check, ``drive.selfcheck``, picks the backend
            whose lanes are most plausible on a sample of the drive; none plausible:
            ``scene.backends.auto_backend``, the model card's pick),
            ``classical``, ``onnx`` or ``oracle`` (ground-truth leaf-id PNGs from ``oracle_labels``,
            named ``<frame index:06d>.png``, as ``slt simulate --labels`` writes them).
        model: ONNX model file or shipped model name (empty: the shipped default).
        oracle_labels: Folder of leaf-id label PNGs for the ``oracle`` backend.
        process_width: Frames are resized to this width (pixels) before every image stage;
            0 keeps the recording's size.
        canonical_camera: Segment each frame in the canonical virtual camera
            (``scene.canonical_backend``: resampled from the drive's camera, labels mapped back
            to the frame's pixels) also with a model trained without it; network backends only.
            A model whose card records a canonical camera (v7, v8) always runs in it;
            off by default for the others (docs/camera.md).
    """

    backend: str = "auto"
    model: str = ""
    oracle_labels: str = ""
    process_width: int = 640
    canonical_camera: bool = False


@dataclass(frozen=True)
class CorridorConfig:
    """The ego-corridor network (corridor paper) and corridor measurement.

    Attributes:
        model: ONNX corridor model file or shipped name (empty: the shipped default; the method
            is marked unavailable when there is none).
        mean_frames: Frames averaged against wiper occlusion (3 in the paper).
        threshold: Probability above which a pixel belongs to the corridor.
        net_every: Run the network on every Nth frame only (1: every frame); the frames in
            between reuse the latest output, so the ``mean_frames`` mean still runs over every
            frame. 2 halves the network's cost at 15 Hz and changes the corridor sizes a little
            (docs/performance.md).
    """

    model: str = ""
    mean_frames: int = 3
    threshold: float = 0.5
    net_every: int = 1


@dataclass(frozen=True)
class CanConfig:
    """CAN decoding.

    Attributes:
        dbcs: DBC files; empty: the shipped ``slt_vehicle.dbc`` and ``slt_mobileye_lanes.dbc``.
            ``BUS=FILE`` binds a DBC to one bus (CAN topic); a plain file decodes every bus.
        speed_signal: Signal holding the vehicle speed (converted to m/s from its DBC unit).
        yaw_rate_signal: Signal holding the yaw rate (converted to rad/s; left positive).
        speed_unit: Unit of the speed signal when its DBC has none or a wrong one ("": DBC).
        yaw_rate_unit: Unit of the yaw-rate signal ("": the DBC's).
        mobileye_mapping: Mobileye message and signal names: ``eyeq`` (public EyeQ / 630 names)
            or ``lka`` (Apollo / AutonomouStuff ``LKA_*``).
        mobileye_right_positive: Mobileye ``C0..C3`` are right positive (the EyeQ convention);
            their sign is flipped into the lane model's left-positive convention.
    """

    dbcs: tuple[str, ...] = ()
    speed_signal: str = "VehicleSpeed"
    yaw_rate_signal: str = "YawRate"
    speed_unit: str = ""
    yaw_rate_unit: str = ""
    mobileye_mapping: str = "eyeq"
    mobileye_right_positive: bool = True


@dataclass(frozen=True)
class RtkConfig:
    """RTK ground truth: which fixes count and how curvature is smoothed.

    Attributes:
        min_status: Smallest ``NavSatStatus.status`` accepted (2 = GBAS / RTK fixed).
        max_horizontal_var_m2: Largest east or north position variance accepted, m^2.
        ds_m: Arc-length resampling step, metres.
        window_m: Savitzky-Golay window, metres.
        polyorder: Savitzky-Golay polynomial order.
        max_gap_s: A gap between fixes longer than this is a dropout, seconds.
        min_run_m: Shorter valid runs are dropped, metres.
        max_frame_gap_s: Frames farther than this from the nearest good fix get no truth, s.
        min_speed_mps: No truth (RTK or yaw-rate) below this speed: standing, crawling, m/s.
        min_step_m: Fixes are decimated to this minimum step before arc length, metres.
        imu_yaw_axis: IMU axis of the yaw rate, with ``-`` when it points down (``z``).
    """

    min_status: int = 2
    max_horizontal_var_m2: float = 0.01
    ds_m: float = 0.5
    window_m: float = 30.0
    polyorder: int = 3
    max_gap_s: float = 0.5
    min_run_m: float = 10.0
    max_frame_gap_s: float = 0.5
    min_speed_mps: float = 2.0
    min_step_m: float = 0.25
    imu_yaw_axis: str = "z"


@dataclass(frozen=True)
class KpiConfig:
    """Availability KPIs (corridor paper IV-B).

    Attributes:
        min_width_m: Narrowest usable corridor, metres.
        max_width_m: Widest usable corridor, metres.
        time_gap_s: The corridor must reach ``speed * time_gap_s`` ahead, seconds.
        width_at_m: Every method's corridor width is measured this far ahead, metres (at the
            corridor's far end when it is shorter); widths and lengths are measured from the
            origin of the camera's vehicle frame (the camera foot with default extrinsics).
        max_outage_frames: Outage limit in frames, used only when ``max_outage_s`` is 0.
        max_outage_s: A sequence stays available with outages up to this long, seconds
            (default the paper's 5 frames at 15 Hz); dropped frames count as outage.
        window_s: Sequence length when the drive is cut into windows, seconds.
        manifest: YAML list of ``{start_s, stop_s, category}`` segments (seconds after the first
            frame); empty: consecutive windows.
        category: Category label of the windows when there is no manifest.
    """

    min_width_m: float = 2.0
    max_width_m: float = 6.0
    time_gap_s: float = 0.7
    width_at_m: float = 10.0
    max_outage_frames: int = 5
    max_outage_s: float = 5.0 / 15.0
    window_s: float = 30.0
    manifest: str = ""
    category: str = ""

    def availability_params(self, frame_rate_hz: float) -> AvailabilityParams:
        """Return the KPI thresholds for a drive at ``frame_rate_hz`` (windows in frames)."""
        shared = {f.name for f in dataclasses.fields(AvailabilityParams)} & {
            f.name for f in dataclasses.fields(self)
        }
        return AvailabilityParams(
            **{name: getattr(self, name) for name in shared},
            window_frames=max(1, round(self.window_s * frame_rate_hz)),
            frame_rate_hz=frame_rate_hz,
        )


@dataclass(frozen=True)
class TrackingConfig(TrackerParams):
    """Lane tracker over travelled distance (Kalman filter + RTS smoother on the SUPER fits).

    The tracker's own parameters (noise levels, gates, smoother, measurement noise) are those
    of :class:`~superlane_tools.lanes.tracker.TrackerParams`, which this
    extends with the two switches below. The per-frame raw ``2*a2`` stays in the outputs
    (``super_curvature``); ``super_road`` / ``super_path`` come from the track when
    ``enabled``, else from the look-ahead alignment alone (``*_sg`` columns).

    Attributes:
        enabled: Track the lane model (False: ``super_road`` / ``super_path`` = ``*_sg``).
        gate_warm_start: Seed the SUPER fit's warm start only from plausible fits (both ego
            lines, slope below the bound) and repeat a collapsed warm-started fit from the
            loss-curve search (False: always the previous frame's fit, as in the paper).
    """

    enabled: bool = True
    gate_warm_start: bool = True


@dataclass(frozen=True)
class OutputConfig:
    """Optional outputs.

    Attributes:
        plots: Write ``plots/*.png``.
        example_frames: Number of Fig. 8 style example frames.
        annotations: Write ``annotations.mcap`` (Foxglove image annotations + lane parameters).
        video: Write ``overlay.mp4``.
        video_fps: Frame rate of the video, Hz (0: the recording's).
    """

    plots: bool = True
    example_frames: int = 2
    annotations: bool = True
    video: bool = False
    video_fps: float = 0.0


@dataclass(frozen=True)
class ReprocessConfig:
    """Everything ``slt reprocess`` needs besides the recording.

    Attributes:
        topics: Stream topics (auto when empty).
        camera: ``auto`` (CameraInfo plus the recording's extrinsics), a profile name or a YAML.
        segmentation: Segmentation backend.
        corridor: Corridor network.
        can: CAN decoding.
        rtk: RTK ground truth.
        kpi: Availability thresholds and sequences.
        output: Optional outputs.
        tracking: Lane tracker over travelled distance.
        fit: Overrides of :class:`superlane_tools.lanes.FitParams` fields (default
            :data:`DEFAULT_FIT`; a ``[fit]`` table is merged over it).
        workers: Threads for decoding and per-frame image stages.
    """

    topics: TopicsConfig = field(default_factory=TopicsConfig)
    camera: str = "auto"
    segmentation: SegmentationConfig = field(default_factory=SegmentationConfig)
    corridor: CorridorConfig = field(default_factory=CorridorConfig)
    can: CanConfig = field(default_factory=CanConfig)
    rtk: RtkConfig = field(default_factory=RtkConfig)
    kpi: KpiConfig = field(default_factory=KpiConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    fit: Mapping[str, Any] = field(default_factory=lambda: dict(DEFAULT_FIT))
    workers: int = 2

    def __post_init__(self) -> None:
        if self.segmentation.backend not in BACKENDS:
            raise ConfigError(
                f"segmentation backend must be one of {BACKENDS}, not {self.segmentation.backend!r}"
            )
        if self.segmentation.backend == "oracle" and not self.segmentation.oracle_labels:
            raise ConfigError("the oracle backend needs segmentation.oracle_labels (a folder)")
        if self.segmentation.process_width < 0 or self.workers < 1:
            raise ConfigError("process_width must be >= 0 and workers >= 1")
        if self.corridor.mean_frames < 1 or self.kpi.window_s <= 0:
            raise ConfigError("corridor.mean_frames must be >= 1 and kpi.window_s > 0")
        if not self.kpi.width_at_m > 0:
            raise ConfigError(f"kpi.width_at_m must be > 0 m, got {self.kpi.width_at_m}")
        if self.corridor.net_every < 1:
            raise ConfigError("corridor.net_every must be >= 1")
        from superlane_tools.lanes import FitParams

        # Parsed once, here: the stages and the kernel warm-up read ``fit_params``.
        object.__setattr__(self, "_fit_params", FitParams.from_dict(dict(self.fit)))

    @property
    def fit_params(self) -> FitParams:
        """The lane fit's parameters: :data:`DEFAULT_FIT` with the ``[fit]`` table over it."""
        params: FitParams = self.__dict__["_fit_params"]
        return params

    def to_dict(self) -> dict[str, Any]:
        """Return the configuration as plain data (for provenance and ``--print-config``)."""
        data = dataclasses.asdict(self)
        data["fit"] = dict(self.fit)
        data["can"]["dbcs"] = list(self.can.dbcs)
        return data

    def with_overrides(self, overrides: Mapping[str, Any]) -> ReprocessConfig:
        """Return a copy with dotted keys replaced (``{"segmentation.backend": "classical"}``).

        Raises:
            ConfigError: For an unknown key.
        """
        data = self.to_dict()
        for dotted, value in overrides.items():
            node = data
            *parents, leaf = dotted.split(".")
            for part in parents:
                if not isinstance(node.get(part), dict):
                    raise ConfigError(f"unknown configuration key {dotted!r}")
                node = node[part]
            if leaf not in node and not (parents == ["fit"]):
                raise ConfigError(f"unknown configuration key {dotted!r}")
            node[leaf] = value
        return config_from_mapping(data)


_SECTIONS: dict[str, type[Any]] = {
    "topics": TopicsConfig,
    "segmentation": SegmentationConfig,
    "corridor": CorridorConfig,
    "can": CanConfig,
    "rtk": RtkConfig,
    "kpi": KpiConfig,
    "output": OutputConfig,
    "tracking": TrackingConfig,
}


def _section(cls: type[Any], data: Any, name: str) -> Any:
    if not isinstance(data, Mapping):
        raise ConfigError(f"config section [{name}] must be a table/mapping")
    known = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise ConfigError(f"unknown keys in [{name}]: {', '.join(unknown)}")
    values: dict[str, Any] = {}
    for key, value in data.items():
        default = getattr(cls(), key)
        if isinstance(default, tuple):
            items = [value] if isinstance(value, str) else value
            if not isinstance(items, list | tuple) or not all(isinstance(v, str) for v in items):
                raise ConfigError(f"{name}.{key} must be a list of strings")
            values[key] = tuple(items)
        elif isinstance(default, bool):
            if not isinstance(value, bool):
                raise ConfigError(f"{name}.{key} must be true or false, got {value!r}")
            values[key] = value
        elif isinstance(default, int | float):
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ConfigError(f"{name}.{key} must be a number, got {value!r}")
            values[key] = type(default)(value) if isinstance(default, float) else value
        elif isinstance(default, str):
            if not isinstance(value, str):
                raise ConfigError(f"{name}.{key} must be a string, got {value!r}")
            values[key] = value
        else:
            values[key] = value
    return cls(**values)


def config_from_mapping(data: Mapping[str, Any]) -> ReprocessConfig:
    """Build a configuration from parsed TOML/YAML; missing keys keep their defaults.

    Raises:
        ConfigError: For unknown keys, wrong types or invalid values.
    """
    if not isinstance(data, Mapping):
        raise ConfigError("the reprocess config must be a mapping of sections")
    top = {f.name for f in dataclasses.fields(ReprocessConfig)}
    unknown = sorted(set(data) - top)
    if unknown:
        raise ConfigError(f"unknown config keys: {', '.join(unknown)} (known: {sorted(top)})")
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key in _SECTIONS:
            kwargs[key] = _section(_SECTIONS[key], value, key)
        elif key == "fit":
            if not isinstance(value, Mapping):
                raise ConfigError("[fit] must be a mapping of FitParams fields")
            kwargs[key] = {**DEFAULT_FIT, **value}
        elif key == "camera":
            if not isinstance(value, str):
                raise ConfigError("camera must be 'auto', a profile name or a YAML path")
            kwargs[key] = value
        elif key == "workers":
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError("workers must be an integer")
            kwargs[key] = value
    try:
        return ReprocessConfig(**kwargs)
    except ConfigError:
        raise
    except Exception as err:  # FitParamsError and friends are UsageErrors: keep one type
        raise ConfigError(f"invalid reprocess config: {err}") from err


def load_config(path: str | os.PathLike[str]) -> ReprocessConfig:
    """Read a reprocess config from a ``.toml`` or ``.yaml``/``.yml`` file.

    Raises:
        ConfigError: If the file cannot be read or parsed, or holds invalid values.
    """
    from superlane_tools.config_files import load_mapping

    src = Path(path)
    data = load_mapping(src)
    try:
        return config_from_mapping(data)
    except ConfigError as err:
        raise ConfigError(f"{src}: {err}") from err


def default_config_yaml() -> str:
    """Return the default configuration as commented YAML (``slt reprocess --print-config``)."""
    import yaml

    body = yaml.safe_dump(ReprocessConfig().to_dict(), sort_keys=False, default_flow_style=False)
    return (
        "# slt reprocess configuration (YAML; the same sections work as TOML tables).\n"
        "# Empty topics are auto-detected by message type. See docs/reprocess.md.\n" + body
    )


def load_manifest(path: str | os.PathLike[str]) -> list[TimeSegment]:
    """Read a KPI manifest: a YAML list of ``{start_s, stop_s, category}`` (seconds).

    Raises:
        ConfigError: If the file cannot be read or a segment is malformed.
    """
    from superlane_tools.config_files import load_document

    specs = []
    for item in load_document(path, "manifest", suffix=".yaml") or []:
        try:
            start, stop = float(item["start_s"]), float(item["stop_s"])
            specs.append(TimeSegment(start, stop, str(item.get("category", ""))))
        except (KeyError, TypeError, ValueError) as err:
            raise ConfigError(f"{path}: bad segment {item!r}") from err
    return specs
