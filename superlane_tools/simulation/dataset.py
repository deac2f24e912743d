"""Training datasets: randomised frames across scenarios with leaf-id and corridor masks.

Layout of the output folder::

    images/000000.jpg      camera image (or .png)
    labels/000000.png      uint8 leaf ids of superlane_tools.hierarchy (0 = void)
    corridor/000000.png    ego corridor, 0 / 255
    index.parquet          one row per sample (columns: see DATASET_INDEX_SCHEMA)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pyarrow as pa

from superlane_tools.camera.model import CameraModel, Extrinsics
from superlane_tools.reporting import Provenance, write_bytes_atomic, write_table
from superlane_tools.reporting.layout import DATASET_INDEX_SCHEMA, DatasetLayout
from superlane_tools.simulation.drive import encode_jpeg, encode_png, sim_camera
from superlane_tools.simulation.errors import ScenarioError, SimulationError
from superlane_tools.simulation.groundtruth import h_samples, lane_truth, tusimple_lanes
from superlane_tools.simulation.scenarios import Scenario, get_scenario, scenario_names
from superlane_tools.simulation.scene import Conditions
from superlane_tools.simulation.world import build_world, frame_world

WORLD_DURATION_S = 40.0
"""Length of each sampled world, seconds of driving."""


@dataclass(frozen=True)
class DatasetResult:
    """What :func:`simulate_dataset` wrote.

    Attributes:
        folder: Output folder.
        samples: Number of samples.
        index: Path of ``index.parquet``.
    """

    folder: Path
    samples: int
    index: Path


def random_camera(base: CameraModel, rng: np.random.Generator, strength: float) -> CameraModel:
    """Perturb focal length, principal point, mount height, pitch, roll and yaw."""
    k = base.intrinsics
    f = float(rng.uniform(1.0 - 0.25 * strength, 1.0 + 0.15 * strength))
    intr = replace(
        k,
        fx=k.fx * f,
        fy=k.fy * f,
        cx=k.cx + float(rng.normal(0.0, 0.02 * strength)) * k.width,
        cy=k.cy + float(rng.normal(0.0, 0.03 * strength)) * k.height,
    )
    e = base.extrinsics
    extr = Extrinsics(
        height_m=float(np.clip(e.height_m + rng.uniform(-0.3, 0.4) * strength, 1.0, 2.2)),
        pitch_rad=e.pitch_rad + float(rng.uniform(-0.04, 0.04)) * strength,
        roll_rad=float(rng.normal(0.0, 0.015)) * strength,
        yaw_rad=float(rng.normal(0.0, 0.02)) * strength,
    )
    return replace(base, intrinsics=intr, extrinsics=extr, name=f"{base.name}_randomized")


def random_conditions(base: Conditions, rng: np.random.Generator, strength: float) -> Conditions:
    """Jitter exposure, noise, blur and JPEG quality; switch on the renderer's randomisation."""
    return replace(
        base,
        exposure=base.exposure * float(np.exp(rng.normal(0.0, 0.2 * strength))),
        noise_sigma=base.noise_sigma + float(rng.uniform(0.0, 3.0)) * strength,
        motion_blur_px=base.motion_blur_px + float(rng.exponential(1.0)) * strength,
        jpeg_quality=int(np.clip(base.jpeg_quality - rng.integers(0, 35) * strength, 40, 100)),
        sun_azimuth_rad=float(rng.uniform(-np.pi, np.pi)) if strength > 0 else base.sun_azimuth_rad,
        randomize=float(strength),
    )


def simulate_dataset(
    out: str | Path,
    frames: int,
    scenarios: Sequence[str] | None,
    seed: int,
    width: int,
    height: int,
    *,
    image_format: str = "jpg",
    randomize: float = 1.0,
    command: str = "",
    progress: Callable[[int, int], None] | None = None,
) -> DatasetResult:
    """Render ``frames`` randomised samples across ``scenarios`` into ``out``.

    Raises:
        ScenarioError: For unknown scenarios, sizes, counts, formats or a non-empty folder.
        SimulationError: If the renderer fails.
    """
    names = tuple(scenarios) if scenarios else scenario_names()
    specs = [get_scenario(n) for n in names]
    _check_options(frames, image_format, randomize)
    base_camera = sim_camera(width, height)
    folder = Path(out)
    if folder.exists() and any(folder.iterdir()):
        raise ScenarioError(f"{folder} exists and is not empty")
    for sub in ("images", "labels", "corridor"):
        (folder / sub).mkdir(parents=True, exist_ok=True)

    rng = np.random.default_rng(seed)
    rows_px = h_samples(height)
    rows: list[dict[str, object]] = []
    for i in range(frames):
        spec = specs[i % len(specs)]
        rows.append(
            _write_sample(folder, i, spec, base_camera, rng, randomize, image_format, rows_px)
        )
        if progress is not None:
            progress(i + 1, frames)
    table = pa.Table.from_pydict(
        {key: [r[key] for r in rows] for key in DATASET_INDEX_SCHEMA.names},
        schema=DATASET_INDEX_SCHEMA,
    )
    provenance = Provenance(
        command=command or "simulate_dataset",
        config={
            "frames": frames,
            "scenarios": list(names),
            "seed": seed,
            "width": width,
            "height": height,
            "image_format": image_format,
            "randomize": randomize,
        },
    )
    index = write_table(table, DatasetLayout(folder).index, provenance)
    return DatasetResult(folder, frames, index)


def _check_options(frames: int, image_format: str, randomize: float) -> None:
    """Raise :class:`ScenarioError` for a sample count, image format or strength out of range."""
    if frames <= 0:
        raise ScenarioError(f"frames must be positive, got {frames}")
    if image_format not in {"jpg", "png"}:
        raise ScenarioError(f"image format must be jpg or png, got {image_format!r}")
    if not 0.0 <= randomize <= 1.0:
        raise ScenarioError(f"randomize must be 0-1, got {randomize}")


def _write_sample(
    folder: Path,
    i: int,
    spec: Scenario,
    base_camera: CameraModel,
    rng: np.random.Generator,
    randomize: float,
    image_format: str,
    rows_px: list[int],
) -> dict[str, object]:
    """Draw sample ``i`` (world, camera, time, conditions), render and write it; return its row.

    Raises:
        SimulationError: If the renderer fails.
    """
    from superlane_tools.simulation.render import render

    world_seed = int(rng.integers(0, 2**31))
    world = build_world(spec, world_seed, WORLD_DURATION_S)
    camera = random_camera(base_camera, rng, randomize)
    t_s = float(rng.uniform(0.0, WORLD_DURATION_S - 1.0))
    fw = frame_world(world, t_s, round(t_s * 1e9), camera, int(rng.integers(0, 2**31)))
    fw = replace(
        fw,
        scene=replace(fw.scene, conditions=random_conditions(fw.scene.conditions, rng, randomize)),
    )
    truth = lane_truth(fw)
    try:
        frame = render(fw.scene)
    except Exception as err:  # the renderer is a separate stage; report it as such
        raise SimulationError(f"renderer failed on sample {i}: {err}") from err
    name = f"{i:06d}"
    image_rel = f"images/{name}.{image_format}"
    if image_format == "jpg":
        data = encode_jpeg(frame.image_bgr, fw.scene.conditions.jpeg_quality)
    else:
        data = encode_png(frame.image_bgr)
    write_bytes_atomic(folder / image_rel, data)
    write_bytes_atomic(folder / "labels" / f"{name}.png", encode_png(frame.labels))
    write_bytes_atomic(
        folder / "corridor" / f"{name}.png", encode_png(frame.corridor.astype(np.uint8) * 255)
    )
    lanes = tusimple_lanes(fw.scene.road, camera, truth.profile_index, rows_px, frame.labels)
    k, e = camera.intrinsics, camera.extrinsics
    return {
        "sample": i,
        "image": image_rel,
        "labels": f"labels/{name}.png",
        "corridor": f"corridor/{name}.png",
        "scenario": spec.name,
        "world_seed": world_seed,
        "t_s": t_s,
        "fx": k.fx,
        "fy": k.fy,
        "cx": k.cx,
        "cy": k.cy,
        "camera_height_m": e.height_m,
        "pitch_rad": e.pitch_rad,
        "roll_rad": e.roll_rad,
        "yaw_rad": e.yaw_rad,
        "line_offset_m": list(truth.offsets_m),
        "line_color": list(truth.colors),
        "line_style": list(truth.styles),
        "lane_heading_rad": truth.heading_rad,
        "lane_curvature": truth.curvature,
        "road_slope": truth.slope,
        "ego_left_line": truth.ego_left,
        "ego_right_line": truth.ego_right,
        "h_samples": rows_px,
        "tusimple_lanes": lanes,
    }
