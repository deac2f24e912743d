"""`slt simulate`: a synthetic drive with exact ground truth, or a training dataset."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.commands.options import OutputGuard, ProgressOpener

if TYPE_CHECKING:
    from superlane_tools.simulation.dataset import DatasetResult
    from superlane_tools.simulation.drive import DriveResult


@dataclass(frozen=True)
class DriveParams:
    """What ``slt simulate --scenario NAME --out PATH`` was asked (see its options)."""

    scenario: str
    out: Path
    duration_s: float = 20.0
    seed: int = 0
    fmt: str = "mcap"
    width: int = 1280
    height: int = 720
    fps: float = 15.0
    jpeg_quality: int | None = None
    rtk_mode: str = "fixed"
    rtk_rate_hz: float = 10.0
    video: str | None = None
    rtk_dropouts_per_min: float = 0.0
    rtk_multipath_per_min: float = 0.0
    labels: bool = False
    speed_kph: bool = False
    imu: bool = False
    second_bus: bool = False
    mobileye_latency_s: float = 0.1
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def scenarios() -> list[tuple[str, str]]:
    """Return every scenario's name and description (``slt simulate --list``)."""
    from superlane_tools.simulation.scenarios import SCENARIOS

    return [(name, spec.description) for name, spec in SCENARIOS.items()]


def drive(params: DriveParams, progress: ProgressOpener) -> DriveResult:
    """Check the scenario and GNSS options, then simulate and write one drive."""
    from superlane_tools.simulation.drive import simulate_drive
    from superlane_tools.simulation.scenarios import get_scenario
    from superlane_tools.simulation.sensors import RtkParams, VehicleOptions

    p = params
    get_scenario(p.scenario)
    rtk = RtkParams(
        rate_hz=p.rtk_rate_hz,
        mode=p.rtk_mode,
        dropouts_per_min=p.rtk_dropouts_per_min,
        multipath_per_min=p.rtk_multipath_per_min,
    )
    rtk.validate()
    vehicle = VehicleOptions(
        speed_kph=p.speed_kph,
        imu=p.imu,
        second_bus=p.second_bus,
        mobileye_latency_s=p.mobileye_latency_s,
    )
    with p.output_guard, progress() as bar:
        return simulate_drive(
            p.scenario,
            p.duration_s,
            p.seed,
            p.fmt,
            p.width,
            p.height,
            p.labels,
            p.out,
            fps=p.fps,
            jpeg_quality=p.jpeg_quality,
            video=p.video,
            rtk=rtk,
            vehicle=vehicle,
            command=p.command,
            progress=bar.update,
        )


@dataclass(frozen=True)
class DatasetParams:
    """What ``slt simulate dataset`` was asked (see its options)."""

    out: Path
    frames: int
    scenarios: list[str] = field(default_factory=list)
    seed: int = 0
    width: int = 1280
    height: int = 720
    image_format: str = "jpg"
    randomize: float = 1.0
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def dataset(params: DatasetParams, progress: ProgressOpener) -> DatasetResult:
    """Write a training set: images, leaf-id masks, corridor masks and its index."""
    from superlane_tools.simulation.dataset import simulate_dataset

    p = params
    names = tuple(n.strip() for item in p.scenarios for n in item.split(",") if n.strip())
    with p.output_guard, progress() as bar:
        return simulate_dataset(
            p.out,
            p.frames,
            names or None,
            p.seed,
            p.width,
            p.height,
            image_format=p.image_format,
            randomize=p.randomize,
            command=p.command,
            progress=bar.update,
        )
