"""The per-drive self-check: ``auto`` tries each segmentation backend on a sample of the drive.

A backend that suits TuSimple's camera may not suit a fleet's. Before the pass, ``auto`` takes
:data:`SAMPLE_CLIPS` short runs of :data:`CLIP_FRAMES` consecutive frames spread evenly over the
drive, runs each candidate backend (``scene.backends.auto_candidates``) through the lane stages
of :class:`~superlane_tools.drive.stages.FrameStages` on them and scores the fitted lanes without
labels (:func:`~superlane_tools.lanes.plausibility.plausibility`). The most plausible backend
runs the drive. When none is plausible the model card's pick runs it, and the report says the
camera looks unlike the training data.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.camera.model import CameraModel
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.errors import SltError
from superlane_tools.lanes.plausibility import Plausibility, plausibility
from superlane_tools.records import Message

SAMPLE_CLIPS = 8
"""Runs of consecutive frames sampled over the drive."""
CLIP_FRAMES = 2
"""Consecutive frames per run (two give the frame-to-frame consistency)."""


@dataclass(frozen=True)
class Trial:
    """One candidate backend's result on the sample.

    Attributes:
        backend: Backend name (``onnx`` or ``classical``).
        model: Model name for ``onnx`` ("" otherwise).
        scores: The plausibility scores (None when the backend could not run).
        error: Why the backend could not run ("" when it ran).
    """

    backend: str
    model: str
    scores: Plausibility | None
    error: str = ""

    @property
    def label(self) -> str:
        """Return ``onnx:<model>`` or the backend name."""
        return f"{self.backend}:{self.model}" if self.model else self.backend

    def line(self) -> str:
        """Return one line: the label, then the scores or why it did not run."""
        if self.scores is None:
            return f"{self.label}: not run ({self.error})"
        verdict = "plausible" if self.scores.plausible else f"NOT plausible: {self.scores.reason}"
        return f"{self.label}: {self.scores.summary()}; {verdict}"


@dataclass(frozen=True)
class SelfCheck:
    """What the self-check found and chose.

    Attributes:
        backend: The backend chosen to run the drive.
        model: Its model ("" for the classical backend).
        trials: Every candidate's result, in the order tried.
        plausible: Whether the chosen backend's fits are plausible.
        reason: Why it was chosen (or that none was plausible).
        n_frames: Frames in the sample.
        seconds: Wall time of the self-check, seconds.
    """

    backend: str
    model: str
    trials: tuple[Trial, ...]
    plausible: bool
    reason: str
    n_frames: int
    seconds: float

    def config(self, config: ReprocessConfig) -> ReprocessConfig:
        """Return ``config`` with the chosen backend and model."""
        seg = replace(config.segmentation, backend=self.backend, model=self.model)
        return replace(config, segmentation=seg)

    def lines(self) -> list[str]:
        """Return the report's lines: the choice and reason, then one line per candidate."""
        head = (
            f"segmentation self-check on {self.n_frames} frames ({self.seconds:.1f} s): "
            f"{self.reason}"
        )
        return [head, *(f"self-check {trial.line()}" for trial in self.trials)]

    def to_dict(self) -> dict[str, Any]:
        """Return the self-check as a JSON-ready mapping (for the provenance)."""
        return {
            "backend": self.backend,
            "model": self.model,
            "plausible": self.plausible,
            "reason": self.reason,
            "n_frames": self.n_frames,
            "seconds": round(self.seconds, 3),
            "trials": [
                {
                    "backend": t.backend,
                    "model": t.model,
                    "error": t.error,
                    "scores": None if t.scores is None else _jsonable(t.scores.to_dict()),
                }
                for t in self.trials
            ],
        }


def _jsonable(data: dict[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in data.items()}


def sample_starts(total: int, clips: int = SAMPLE_CLIPS, length: int = CLIP_FRAMES) -> list[int]:
    """Return the first frame index of each sampled run, spread evenly over ``total`` frames.

    At most ``clips`` runs of ``length`` frames, never overlapping (fewer on a short drive).
    """
    last = total - length
    if last < 0:
        return [0] if total else []
    n = min(clips, total // length)  # runs never overlap
    if n == 1:
        return [last // 2]
    return sorted({round(i * last / (n - 1)) for i in range(n)})


def sample_frames(
    messages: Iterable[Message], total: int, clips: int = SAMPLE_CLIPS, length: int = CLIP_FRAMES
) -> list[list[tuple[int, Message]]]:
    """Pick the sampled runs ``(index, message)`` out of a drive's image messages, in order."""
    starts = sample_starts(total, clips, length)
    wanted = {s + k: n for n, s in enumerate(starts) for k in range(length)}
    runs: list[list[tuple[int, Message]]] = [[] for _ in starts]
    if not wanted:
        return runs
    last = max(wanted)
    for index, msg in enumerate(messages):
        if index in wanted:
            runs[wanted[index]].append((index, msg))
        if index >= last:
            break
    return [run for run in runs if run]


Sample = Sequence[Sequence[tuple[int, Any]]]
"""Runs of consecutive frames ``(index, image message or BGR image)``."""


def try_backend(config: ReprocessConfig, camera: CameraModel, runs: Sample) -> Plausibility:
    """Run the lane stages with ``config``'s backend on the runs; score the fits."""
    from superlane_tools.drive.stages import FrameStages, Prepared

    stages = FrameStages(config, camera, lanes_only=True)

    def prepare(index: int, frame: Any) -> Prepared:
        if isinstance(frame, np.ndarray):
            return stages.prepare_image(Prepared(index, 0, None), frame)
        return stages.prepare(index, frame)

    # every image stage first: on a first run they overlap the fit's kernels compiling
    prepared = [[prepare(index, frame) for index, frame in run] for run in runs]
    clips = []
    for run in prepared:
        stages.restart()
        clips.append([stages.finish(prep).fit for prep in run])
    return plausibility(clips)


def self_check(
    config: ReprocessConfig,
    camera: CameraModel,
    runs: Sample,
    candidates: Sequence[tuple[str, str]],
    fallback: tuple[str, str],
) -> SelfCheck:
    """Try each candidate backend on the sampled runs; choose the most plausible.

    Args:
        config: The run's configuration (its segmentation backend is replaced per candidate).
        camera: The drive's camera.
        runs: The sampled runs of consecutive frames (:func:`sample_frames`).
        candidates: ``(backend, model)`` pairs, in order of preference (a tie goes to the
            first).
        fallback: ``(backend, model)`` to run when none is plausible.
    """
    t0 = time.perf_counter()
    trials = []
    for backend, model in candidates:
        seg = replace(config.segmentation, backend=backend, model=model)
        try:
            scores = try_backend(replace(config, segmentation=seg), camera, runs)
        except SltError as err:
            trials.append(Trial(backend, model, None, str(err)))
            continue
        trials.append(Trial(backend, model, scores))
    n_frames = sum(len(run) for run in runs)
    ran = [t for t in trials if t.scores is not None and t.scores.plausible]
    if ran:
        best = max(ran, key=lambda t: t.scores.score if t.scores else 0.0)
        assert best.scores is not None
        others = [t for t in trials if t is not best]
        why = f"{best.label} chosen: most plausible lanes (score {best.scores.score:.2f})"
        if others:
            why += "; " + ", ".join(_other(t) for t in others)
        return SelfCheck(best.backend, best.model, tuple(trials), True, why, n_frames, _since(t0))
    label = f"{fallback[0]}:{fallback[1]}" if fallback[1] else fallback[0]
    failed = "; ".join(
        f"{t.label}: {t.scores.reason if t.scores is not None else 'not run'}" for t in trials
    )
    why = f"no backend plausible on this drive ({failed}); {label} runs it (model card's pick)"
    return SelfCheck(*fallback, tuple(trials), False, why, n_frames, _since(t0))


def _other(trial: Trial) -> str:
    if trial.scores is None:
        return f"{trial.label} not run"
    state = "plausible" if trial.scores.plausible else "not plausible"
    return f"{trial.label} {trial.scores.score:.2f} ({state})"


def _since(t0: float) -> float:
    return time.perf_counter() - t0


def drive_self_check(
    path: Path, topic: str, config: ReprocessConfig, camera: CameraModel
) -> SelfCheck | str:
    """Run the self-check on a drive when its backend is ``auto``; else say why it is skipped.

    The sample is read through its own handle on the recording, so that what the drive's one
    pass skips (corrupt messages) is counted once.

    Args:
        path: The recording.
        topic: Its camera topic.
        config: The run's configuration.
        camera: The drive's camera.

    Returns:
        The self-check, or the line saying it was skipped (an explicit backend or model).
    """
    from superlane_tools.recording.open import open_recording
    from superlane_tools.recording.video import decode_video
    from superlane_tools.scene.backends import auto_candidates

    seg = config.segmentation
    if seg.backend != "auto" or seg.model:
        chosen = f"--model {seg.model}" if seg.model else f"--backend {seg.backend}"
        return f"segmentation self-check skipped: backend chosen explicitly ({chosen})"
    with open_recording(path) as recording:
        total = next((t.message_count for t in recording.topics() if t.topic == topic), None)
        if total is None:
            total = sum(1 for _ in recording.raw_messages(topics=[topic]))
        runs = sample_frames(decode_video(recording.messages(topics=[topic])), total)
    if not runs:
        return "segmentation self-check skipped: no camera frames to sample"
    return self_check(config, camera, runs, auto_candidates(), _card_pick())


def _card_pick() -> tuple[str, str]:
    from superlane_tools.scene.backends import auto_backend, auto_candidates

    name, _ = auto_backend(None)
    return name, next((m for b, m in auto_candidates() if b == name), "")


def images_self_check(
    images: Sequence[Path], camera: CameraModel, config: ReprocessConfig | None = None
) -> SelfCheck:
    """Run the self-check on a sample of an image folder's images (sorted by name).

    Runs of :data:`CLIP_FRAMES` neighbouring images, spread evenly over the folder, as for a
    drive; unreadable images are left out of the sample.
    """
    import cv2

    from superlane_tools.scene.backends import auto_candidates

    starts = sample_starts(len(images))
    runs = []
    for start in starts:
        run = []
        for index in range(start, min(start + CLIP_FRAMES, len(images))):
            image = cv2.imread(str(images[index]), cv2.IMREAD_COLOR)
            if image is not None:
                run.append((index, np.asarray(image)))
        if run:
            runs.append(run)
    cfg = config or ReprocessConfig()
    return self_check(cfg, camera, runs, auto_candidates(), _card_pick())
