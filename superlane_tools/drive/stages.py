"""Per-frame stages of ``slt reprocess``: image work (thread-safe) and sequential state.

:meth:`FrameStages.prepare` does everything that depends on one frame only (decode, resize,
segmentation, lane / road pixels, corridor network, Hough baseline) and runs in a thread pool;
cv2 and onnxruntime release the GIL. :meth:`FrameStages.finish` runs in frame order and holds
the state that spans frames: the SUPER fit's warm start and the corridor's three-frame mean.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Iterator
from concurrent.futures import Future, wait
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.corridor import (
    CorridorGeometry,
    CorridorParams,
    HoughParams,
    HoughResult,
    corridor_from_lanes,
    corridor_from_mask,
    detect_ego_lane,
)
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.lanes import LaneFit
from superlane_tools.lanes.kernel_cache import kernels_loading, warm_up_in_background
from superlane_tools.lanes.points import lane_points, road_points
from superlane_tools.lanes.sequence import SequentialFit, max_plausible_slope
from superlane_tools.recording.images import decode_frame, decode_reduced
from superlane_tools.records import Message
from superlane_tools.scene.oracle import OracleLabels

FloatArray = NDArray[np.float64]
NO_CORRIDOR_MODEL = "no corridor model"
WARM_UP_LOOK_AHEAD = 256
"""Frames the image stages may run ahead of the fit while its kernels load or compile.

The first run after an install compiles the lane fit's kernels (about 10 s of one core, in a
child process); the fit is sequential, so without this the pool would idle behind the first
frame's fit. Each frame waiting holds its image and labels at processing size (about 1.6 MB at
640 x 360), so the buffer is bounded (about 0.4 GB, on that first run only); results do not
depend on it (the same kernels fit the same frames in order).
"""
CATCH_UP = 2
"""Frames of a warm-up backlog finished per frame submitted, once the kernels are loaded."""


@dataclass
class Prepared:
    """The frame-local results of one frame (output of :meth:`FrameStages.prepare`).

    Attributes:
        index: Frame index in the recording (0-based).
        log_time_ns: Log time of the image message, ns.
        stamp_ns: Header stamp, ns (None when absent).
        source_size: ``(width, height)`` of the recorded image, pixels (0 when undecodable).
        error: Why the frame could not be decoded ("" when it could).
        image: The frame at processing size (BGR), or None.
        labels: Leaf-id label image at processing size, or None.
        lane_uv: Lane pixels at processing size.
        codes: Attribute codes of ``lane_uv``.
        road_uv: Road pixels, or None when the fit will not use them.
        corridor_prob: Corridor probability at the network's input size, or None.
        hough: The Hough baseline's result, or None.
        net_corridor: Corridor geometry of the network's three-frame mean, once
            :meth:`FrameStages.smooth` has run on this frame (None before).
        net_mask: That averaged corridor probability, or None.
        seconds: Wall time per stage, seconds.
        cpu_seconds: CPU time of the running thread per stage, seconds.
    """

    index: int
    log_time_ns: int
    stamp_ns: int | None
    source_size: tuple[int, int] = (0, 0)
    error: str = ""
    image: NDArray[np.uint8] | None = None
    labels: NDArray[np.uint8] | None = None
    lane_uv: FloatArray = field(default_factory=lambda: np.empty((0, 2)))
    codes: NDArray[np.intp] = field(default_factory=lambda: np.empty(0, np.intp))
    road_uv: FloatArray | None = None
    corridor_prob: NDArray[np.float32] | None = None
    hough: HoughResult | None = None
    net_corridor: CorridorGeometry | None = None
    net_mask: NDArray[np.float32] | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    cpu_seconds: dict[str, float] = field(default_factory=dict)

    def clock(self) -> _StageClock:
        """Return a clock that records stage times into this frame."""
        return _StageClock(self.seconds, self.cpu_seconds)


class _StageClock:
    """Records wall and thread CPU time of consecutive stages (thread CPU excludes other jobs)."""

    def __init__(self, wall: dict[str, float], cpu: dict[str, float]) -> None:
        self._wall, self._cpu = wall, cpu
        self._t, self._c = time.perf_counter(), time.thread_time()

    def lap(self, stage: str) -> None:
        """Charge the time since the previous lap (or creation) to ``stage``."""
        t, c = time.perf_counter(), time.thread_time()
        self._wall[stage] = self._wall.get(stage, 0.0) + t - self._t
        self._cpu[stage] = self._cpu.get(stage, 0.0) + c - self._c
        self._t, self._c = t, c


@dataclass
class Finished:
    """A frame after the sequential stages.

    Attributes:
        prepared: The frame-local results.
        fit: The SUPER multi-lane fit.
        super_corridor: Corridor geometry from the fitted ego lines.
        net_corridor: Corridor geometry from the (three-frame mean) corridor network.
        net_mask: The averaged corridor probability, or None.
        camera: The camera at processing size.
    """

    prepared: Prepared
    fit: LaneFit
    super_corridor: CorridorGeometry
    net_corridor: CorridorGeometry
    net_mask: NDArray[np.float32] | None
    camera: CameraModel


class FrameStages:
    """Builds the backends once and runs the per-frame stages.

    Args:
        config: The run's configuration.
        camera: Camera of the recorded frames (resized to each frame's size as needed).
        lanes_only: Run only the stages of the lane fit (decode, segmentation, points, fit;
            no corridor network, no Hough), as the per-drive self-check does. Such stages keep
            every label image they compute (:attr:`sampled`), by log time.
        reuse: The self-check's stages of the backend chosen for the drive: their loaded
            backend runs the pass, and a frame they segmented is not segmented again when its
            image is the same (pixel for pixel: the labels are then the same).

    Raises:
        UsageError: If a requested backend or model cannot be used.
    """

    def __init__(
        self,
        config: ReprocessConfig,
        camera: CameraModel,
        lanes_only: bool = False,
        reuse: FrameStages | None = None,
    ) -> None:
        self.config = config
        self.camera = camera
        self.lanes_only = lanes_only
        self.fit_params = config.fit_params
        warm_up_in_background(self.fit_params.backend)  # no-op when loaded or loading
        self.notes: list[str] = []
        self.models: dict[str, str] = {}
        self._cameras: dict[tuple[int, int], CameraModel] = {}
        self._oracle: OracleLabels | None = None
        self.sampled: dict[int, tuple[NDArray[np.uint8], NDArray[np.uint8]]] = {}
        """Label images computed with ``lanes_only``: log time -> (image, labels)."""
        self._reusable: dict[int, tuple[NDArray[np.uint8], NDArray[np.uint8]]] = {}
        self._reused: list[int] = []  # log times; list.append is atomic on the frame pool
        self.backend_name: str
        self._backend: Any
        if reuse is not None and _same_segmentation(reuse, config, camera):
            self.backend_name, self._backend = reuse.backend_name, reuse._backend
            self.models.update(reuse.models)
            self.notes += reuse.notes
            self._reusable, reuse.sampled = reuse.sampled, {}  # handed over, not copied
        else:
            self.backend_name, self._backend = self._segmentation_backend()
        self.corridor_unavailable = ""
        self._corridor = None if lanes_only else self._corridor_model()
        self._smoother: Any = None
        self._held_prob: NDArray[np.float32] | None = None  # corridor.net_every > 1
        if self._corridor is not None:
            from superlane_tools.scene.corridor_runtime import CorridorSmoother

            self._smoother = CorridorSmoother(config.corridor.mean_frames)
        self.max_slope = max_plausible_slope(self.fit_params, config.tracking.max_slope_fraction)
        self._sequence = SequentialFit(
            self.fit_params, self.max_slope, config.tracking.gate_warm_start
        )
        at = config.kpi.width_at_m
        self._corridor_params = CorridorParams(threshold=config.corridor.threshold, width_at_m=at)
        self._hough_params = HoughParams(width_at_m=at)

    def _segmentation_backend(self) -> tuple[str, Any]:
        seg = self.config.segmentation
        if seg.backend == "oracle":
            self._oracle = OracleLabels(seg.oracle_labels)
            self.notes.append(
                f"ORACLE segmentation: ground-truth label images from {self._oracle.folder} "
                "(measures the lane stage on its own)"
            )
            return "oracle", None
        from superlane_tools.scene.backends import auto_backend, backend_from_name

        name = seg.backend
        if name == "auto":
            name, note = auto_backend(seg.model)
            if note:
                self.notes.append(note)
        if name == "onnx":  # one thread each: frames run on the pass's pool
            # a model trained in the canonical camera always runs in it; the option applies
            # it to the others too
            backend: Any = backend_from_name(
                "onnx",
                model=seg.model or None,
                camera=self.camera,
                canonical=seg.canonical_camera,
                threads=1,
            )
            network = getattr(backend, "inner", backend)  # the model, wrapped or not
            self.models[network.name] = network.sha256
            return backend.name, backend
        if seg.canonical_camera:
            self.notes.append(
                f"canonical camera off for the {name} backend: it works in the drive's own "
                "camera (the canonical camera is for networks)"
            )
        backend = backend_from_name(name, camera=self.camera)
        return name, backend

    def _corridor_model(self) -> Any:
        from superlane_tools.models import list_models
        from superlane_tools.scene.onnx_backend import DEFAULT_CORRIDOR_MODEL

        model = self.config.corridor.model
        if not model and DEFAULT_CORRIDOR_MODEL not in list_models():
            self.corridor_unavailable = NO_CORRIDOR_MODEL
            self.notes.append(
                f"corridor network unavailable: {NO_CORRIDOR_MODEL} "
                f"({DEFAULT_CORRIDOR_MODEL} is not shipped; pass corridor.model)"
            )
            return None
        from superlane_tools.scene.corridor_runtime import OnnxCorridorModel

        net = OnnxCorridorModel(model or None, threads=1)
        self.models[net.name] = net.sha256
        return net

    def camera_for(self, width: int, height: int) -> CameraModel:
        """Return the camera resized to ``width x height`` pixels (cached)."""
        key = (width, height)
        cam = self._cameras.get(key)
        if cam is None:
            base = self.camera
            cam = base if (base.width, base.height) == key else base.resized(width, height)
            self._cameras[key] = cam
        return cam

    def process_size(self, width: int, height: int) -> tuple[int, int]:
        """Return the processing size for a recorded frame size."""
        target = self.config.segmentation.process_width
        if target <= 0 or target >= width:
            return width, height
        return target, max(8, round(height * target / width))

    def prepare(self, index: int, msg: Message) -> Prepared:
        """Run the frame-local stages of one image message (thread-safe)."""
        out = Prepared(index, msg.log_time_ns, msg.stamp_ns)
        clock = out.clock()
        reduced = decode_reduced(msg, self.config.segmentation.process_width)
        if reduced is not None:
            image, (width, height) = reduced
        else:
            try:
                image = decode_frame(msg)
            except ValueError as err:
                out.error = str(err)
                clock.lap("decode")
                return out
            height, width = image.shape[:2]
        out.source_size = (width, height)
        return self.prepare_image(out, image, clock)

    def prepare_image(
        self, out: Prepared, image: NDArray[np.uint8], clock: _StageClock | None = None
    ) -> Prepared:
        """Run the frame-local stages on a decoded image (BGR) into ``out`` (thread-safe).

        ``out.source_size`` is the recorded size (set from ``image`` when unset); ``image`` may
        already be reduced towards the processing size.
        """
        import cv2

        clock = clock or out.clock()
        index = out.index
        if out.source_size == (0, 0):
            out.source_size = (image.shape[1], image.shape[0])
        pw, ph = self.process_size(*out.source_size)
        if (pw, ph) != image.shape[1::-1]:
            image = np.asarray(cv2.resize(image, (pw, ph), interpolation=cv2.INTER_AREA))
        out.image = image
        cam = self.camera_for(pw, ph)
        clock.lap("decode")
        out.labels = self._segment(out, image)
        clock.lap("segmentation")
        seed = self.fit_params.seed
        out.lane_uv, out.codes = lane_points(out.labels, seed=seed)
        p = self.fit_params
        if p.lambda_road > 0 and (
            p.road_term == "always"
            or (p.road_term == "auto" and out.lane_uv.shape[0] < p.road_term_below)
        ):
            out.road_uv = road_points(out.labels, seed=seed)
        clock.lap("points")
        if self._corridor is not None and index % self.config.corridor.net_every == 0:
            out.corridor_prob = self._corridor.probability_at_input(image)
        clock.lap("corridor_net")
        if not self.lanes_only:
            out.hough = detect_ego_lane(image, cam, self._hough_params)
        clock.lap("hough")
        return out

    def _segment(self, out: Prepared, image: NDArray[np.uint8]) -> NDArray[np.uint8]:
        if self._oracle is not None:
            return self._oracle.labels(out.index, image.shape[1], image.shape[0])
        known = self._reusable.pop(out.log_time_ns, None)  # atomic: frames run on a pool
        if known is not None and known[0].shape == image.shape and np.array_equal(known[0], image):
            self._reused.append(out.log_time_ns)
            return known[1]
        labels: NDArray[np.uint8] = self._backend.segment(image)
        if self.lanes_only:
            self.sampled[out.log_time_ns] = (image, labels)
        return labels

    @property
    def reused(self) -> int:
        """Frames whose label image came from :attr:`sampled` of the ``reuse`` stages."""
        return len(self._reused)

    def due(self, pending: deque[Future[Prepared]], workers: int) -> Iterator[Prepared]:
        """Pop the prepared frames that :meth:`finish` must take now, oldest first.

        Normally all but ``2 * workers`` of them. While the fit's kernels load on a side
        thread (:func:`~superlane_tools.lanes.kernel_cache.warm_up_in_background`; on the
        first run after an install that means compiling them in a child process), up to
        :data:`WARM_UP_LOOK_AHEAD` may wait, so the image stages keep working instead of
        idling behind the first fit; the newest frame is awaited first, so that one core
        prepares frames while the compiler, the critical path of that run, has the other;
        and this thread runs :meth:`smooth` on the waiting frames. The backlog left when the
        kernels are loaded is taken :data:`CATCH_UP` frames per call, so the pool keeps
        preparing new frames while the fit catches up.
        """
        if kernels_loading(self.fit_params.backend):
            wait([pending[-1]])
            for future in pending:  # what can run before the fit does, in frame order
                if not future.done():
                    break
                self.smooth(future.result())
            keep = max(2 * workers, WARM_UP_LOOK_AHEAD)
        else:
            keep = max(2 * workers, len(pending) - CATCH_UP)
        while len(pending) > keep:
            yield pending.popleft().result()

    def restart(self) -> None:
        """Forget the state that spans frames (the fit's warm start, the corridor mean)."""
        self._sequence.reset()
        self._held_prob = None
        if self._smoother is not None:
            self._smoother.reset()

    def smooth(self, prep: Prepared) -> CorridorGeometry:
        """Run the corridor network's three-frame mean on ``prep``: in frame order, once each.

        It does not depend on the fit, so it may run ahead of it (while the fit's kernels
        compile); :meth:`finish` runs it on frames it has not seen yet.

        Returns:
            ``prep.net_corridor``, the corridor geometry of the averaged probability.
        """
        if prep.net_corridor is not None:
            return prep.net_corridor
        clock = prep.clock()
        net = CorridorGeometry(math.nan, math.nan, 0)
        if prep.image is None:
            self._held_prob = None
            if self._smoother is not None:
                self._smoother.reset()
        else:
            if prep.corridor_prob is not None:
                self._held_prob = prep.corridor_prob
            if self._smoother is not None and self._held_prob is not None:
                height, width = prep.image.shape[:2]
                prep.net_mask = self._smoother.update(self._held_prob)
                net = corridor_from_mask(
                    prep.net_mask, self.camera_for(width, height), self._corridor_params
                )
        prep.net_corridor = net
        clock.lap("corridor_geometry")
        return net

    def finish(self, prep: Prepared) -> Finished:
        """Run the sequential stages (warm-started fit, corridor mean) in frame order."""
        net = self.smooth(prep)
        if prep.image is None:
            self._sequence.reset()
            nan = CorridorGeometry(math.nan, math.nan, 0)
            return Finished(prep, LaneFit(reason="frame not decoded"), nan, nan, None, self.camera)
        height, width = prep.image.shape[:2]
        cam = self.camera_for(width, height)
        clock = prep.clock()
        fit = self._sequence.fit(prep.lane_uv, prep.road_uv, cam, prep.codes)
        left = fit.lanes[fit.ego_left] if fit.ego_left >= 0 else None
        right = fit.lanes[fit.ego_right] if fit.ego_right >= 0 else None
        reach = (
            min(left.range_max_m, right.range_max_m)
            if left is not None and right is not None
            else None
        )
        super_corr = corridor_from_lanes(
            (left.offset_m, left.a1, left.a2) if left else None,
            (right.offset_m, right.a1, right.a2) if right else None,
            reach,
            self.config.kpi.width_at_m,
            cam.extrinsics.x_m,  # the fit's lines start at the camera foot
        )
        clock.lap("lane_fit")
        return Finished(prep, fit, super_corr, net, prep.net_mask, cam)


def _same_segmentation(stages: FrameStages, config: ReprocessConfig, camera: CameraModel) -> bool:
    """Return True when ``stages`` segment as ``config`` would, for frames of ``camera``."""
    return stages.config.segmentation == config.segmentation and stages.camera == camera
