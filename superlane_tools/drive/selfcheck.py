"""The per-drive self-check: ``auto`` tries each segmentation backend on a sample of the drive.

A backend that suits TuSimple's camera may not suit a fleet's. Before the pass, ``auto`` takes
:data:`SAMPLE_CLIPS` short runs of :data:`CLIP_FRAMES` consecutive frames spread evenly over the
drive, runs each candidate backend (``scene.backends.auto_candidates``) through the lane stages
of :class:`~superlane_tools.drive.stages.FrameStages` on them and scores the fitted lanes without
labels (:func:`~superlane_tools.lanes.plausibility.plausibility`). The most plausible backend
runs the drive. When none is plausible the model card's pick runs it, and the report says the
camera looks unlike the training data.

The score sees reach: each sample frame's SUPER corridor (the fitted ego lines) is judged by the
availability rule (``corridor.availability``) at :data:`SAMPLE_SPEED_MPS`, and the reach share
and the available share join the plausibility score. Scores within :data:`TIE` of the best are
a tie, and a tie keeps the backend that cost less CPU per sample frame (measured here, on the
same frames). Candidates run in order (``auto_candidates``: fastest model first, the classical
backend last); one whose lanes are plausible and available on every sample frame ends the check
early (a slower candidate could at best tie on what the drive needs, and a tie keeps the faster).

Cost: the sample is read from the drive's open recording through the one frame reader
(``recording.camera_frames``), seeking to each run (video from the keyframe before it); each
frame is decoded once for every candidate. The chosen candidate's stages go to the pass
(``SelfCheck.stages``): its loaded backend runs the drive, and the sample frames it segmented
are not segmented again (``FrameStages(reuse=...)``: reused when the pass decodes the same
pixels), so what the check adds to a drive is the other candidates, the sample's reading and
its fits.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.camera.model import CameraModel
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.errors import SltError
from superlane_tools.lanes.plausibility import Plausibility, Reach, plausibility
from superlane_tools.recording.base import Recording
from superlane_tools.records import Message

SAMPLE_CLIPS = 6
"""Runs of consecutive frames sampled over the drive."""
CLIP_FRAMES = 2
"""Consecutive frames per run (two give the frame-to-frame consistency)."""
SAMPLE_SPEED_MPS = 25.0
"""Speed at which the sample's reach is judged (90 km/h; the check reads no speed signal)."""
TIE = 0.02
"""Scores this close to the best are a tie: the faster backend is kept."""


@dataclass(frozen=True)
class Trial:
    """One candidate backend's result on the sample.

    Attributes:
        backend: Backend name (``onnx`` or ``classical``).
        model: Model name for ``onnx`` ("" otherwise).
        scores: The plausibility scores (None when the backend could not run).
        error: Why the backend could not run ("" when it ran).
        cpu_ms: CPU milliseconds per sample frame of this candidate (segmentation and fit).
    """

    backend: str
    model: str
    scores: Plausibility | None
    error: str = ""
    cpu_ms: float = math.nan

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
        cpu_s: CPU time of the self-check (this process, every thread), seconds.
        stages: The chosen candidate's lane stages (``drive.stages.FrameStages``, with its
            sample's label images) for the pass to reuse; None when none was chosen.
    """

    backend: str
    model: str
    trials: tuple[Trial, ...]
    plausible: bool
    reason: str
    n_frames: int
    seconds: float
    cpu_s: float = math.nan
    stages: Any = field(default=None, compare=False, repr=False)

    @property
    def label(self) -> str:
        """Return ``onnx:<model>`` or the backend name of the chosen backend."""
        return f"{self.backend}:{self.model}" if self.model else self.backend

    def reason_line(self) -> str:
        """Return one sentence: which backend ran the drive and why (CPU in :meth:`to_dict`)."""
        head = f"segmentation self-check on {self.n_frames} frames ({self.seconds:.1f} s)"
        return f"{head}: {self.reason}"

    def config(self, config: ReprocessConfig) -> ReprocessConfig:
        """Return ``config`` with the chosen backend and model."""
        seg = replace(config.segmentation, backend=self.backend, model=self.model)
        return replace(config, segmentation=seg)

    def lines(self, reused: int = 0) -> list[str]:
        """Return the report's lines: :meth:`reason_line`, one line per candidate, the cost.

        ``reused``: sample frames whose label images the pass took from the check.
        """
        trials = [f"self-check {trial.line()}" for trial in self.trials]
        if math.isnan(self.cpu_s):
            return [self.reason_line(), *trials]
        cost = f"self-check cost: {self.cpu_s:.2f} s CPU"
        if reused:
            cost += f"; the pass reused {reused} of its segmented sample frames"
        return [self.reason_line(), *trials, cost]

    def to_dict(self) -> dict[str, Any]:
        """Return the self-check as a JSON-ready mapping (for the provenance)."""
        return {
            "backend": self.backend,
            "model": self.model,
            "plausible": self.plausible,
            "reason": self.reason,
            "n_frames": self.n_frames,
            "seconds": round(self.seconds, 3),
            "cpu_s": round(self.cpu_s, 3),
            "trials": [
                {
                    "backend": t.backend,
                    "model": t.model,
                    "error": t.error,
                    "cpu_ms": None if math.isnan(t.cpu_ms) else round(t.cpu_ms, 1),
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
"""Runs of consecutive frames ``(key, BGR image or (source size, BGR image))``; a drive's key is
the frame's log time (ns: the pass finds the sample's label images by it), a folder's the
image's index."""


def try_backend(
    config: ReprocessConfig, camera: CameraModel, runs: Sample
) -> tuple[Plausibility, Any]:
    """Run the lane stages with ``config``'s backend on the runs; score the fits and reach.

    Returns:
        The scores, and the stages (``drive.stages.FrameStages``, holding the sample's label
        images by key) for the pass to reuse.
    """
    from superlane_tools.corridor.availability import frame_availability
    from superlane_tools.drive.stages import FrameStages, Prepared

    stages = FrameStages(config, camera, lanes_only=True)

    def prepare(key: int, frame: Any) -> Prepared:
        if isinstance(frame, np.ndarray):
            return stages.prepare_image(Prepared(key, key, None), frame)
        size, image = frame
        out = Prepared(key, key, None)
        out.source_size = size
        return stages.prepare_image(out, image)

    # every image stage first: on a first run they overlap the fit's kernels compiling
    prepared = [[prepare(index, frame) for index, frame in run] for run in runs]
    clips, widths, lengths = [], [], []
    for run in prepared:
        stages.restart()
        finished = [stages.finish(prep) for prep in run]
        clips.append([done.fit for done in finished])
        widths += [done.super_corridor.width_m for done in finished]
        lengths += [done.super_corridor.length_m for done in finished]
    rule = config.kpi.availability_params(15.0)
    available = frame_availability(widths, lengths, SAMPLE_SPEED_MPS, rule).available
    reach = Reach(lengths, available.tolist(), SAMPLE_SPEED_MPS * rule.time_gap_s)
    return plausibility(clips, reach=reach), stages


def self_check(
    config: ReprocessConfig,
    camera: CameraModel,
    runs: Sample,
    candidates: Sequence[tuple[str, str]],
    fallback: tuple[str, str] | Callable[[], tuple[str, str]],
) -> SelfCheck:
    """Try the candidate backends on the sampled runs; choose the most plausible.

    Args:
        config: The run's configuration (its segmentation backend is replaced per candidate).
        camera: The drive's camera.
        runs: The sampled runs of consecutive frames (:func:`sample_frames`), decoded once.
        candidates: ``(backend, model)`` pairs, fastest first (a tie keeps the faster; one
            plausible and available on every sample frame ends the check).
        fallback: ``(backend, model)`` to run when none is plausible, or a function returning
            it (called only then: reading the card pick costs time).
    """
    t0, c0 = time.perf_counter(), time.process_time()
    n_frames = sum(len(run) for run in runs)
    trials: list[Trial] = []
    stages: dict[str, Any] = {}  # by trial label: the chosen one's goes to the pass
    for backend, model in candidates:
        seg = replace(config.segmentation, backend=backend, model=model)
        c1 = time.process_time()
        try:
            scores, stages[f"{backend}:{model}"] = try_backend(
                replace(config, segmentation=seg), camera, runs
            )
        except SltError as err:
            trials.append(Trial(backend, model, None, str(err)))
            continue
        cpu_ms = 1000.0 * (time.process_time() - c1) / max(n_frames, 1)
        trials.append(Trial(backend, model, scores, cpu_ms=cpu_ms))
        if scores.plausible and scores.available >= 1.0:
            break  # every sample frame available: a slower candidate could at best tie
    if best_trial_plausible(trials) or not callable(fallback):
        pick = fallback if not callable(fallback) else ("", "")
    else:
        pick = fallback()
    best, why = choose(trials, pick)
    untried = [f"{b}:{m}" if m else b for b, m in candidates[len(trials) :]]
    if untried:
        why += f"; {', '.join(untried)} not tried (every sample frame was available)"
    backend, model = (best.backend, best.model) if best is not None else pick
    cpu_s = time.process_time() - c0
    chosen = stages.get(f"{backend}:{model}")
    return SelfCheck(
        backend, model, tuple(trials), best is not None, why, n_frames, _since(t0), cpu_s, chosen
    )


def best_trial_plausible(trials: Sequence[Trial]) -> bool:
    """Return True when some trial's lanes are plausible."""
    return any(t.scores is not None and t.scores.plausible for t in trials)


def choose(trials: Sequence[Trial], fallback: tuple[str, str]) -> tuple[Trial | None, str]:
    """Return the chosen trial (None: none plausible) and the sentence saying why.

    The most plausible trial wins; trials within :data:`TIE` of its score are a tie, and the
    one with the least CPU per sample frame among them is kept.
    """
    ran = [t for t in trials if t.scores is not None and t.scores.plausible]
    if not ran:
        label = f"{fallback[0]}:{fallback[1]}" if fallback[1] else fallback[0]
        failed = "; ".join(
            f"{t.label}: {t.scores.reason if t.scores is not None else 'not run'}" for t in trials
        )
        return None, (
            f"no backend plausible on this drive ({failed}); {label} runs it (model card's pick)"
        )
    top = max(_score(t) for t in ran)
    tied = [t for t in ran if _score(t) >= top - TIE]
    best = min(tied, key=lambda t: t.cpu_ms if not math.isnan(t.cpu_ms) else math.inf)
    assert best.scores is not None
    reach = best.scores
    why = (
        f"{best.label} ran it: most plausible lanes (score {reach.score:.2f}, reach "
        f"{reach.reach_m:.1f} m, {reach.available:.0%} of the sample available at "
        f"{SAMPLE_SPEED_MPS * 3.6:.0f} km/h)"
    )
    if len(tied) > 1:
        slower = ", ".join(f"{t.label} {_score(t):.2f}" for t in tied if t is not best)
        why += f", tied with {slower} and faster (less CPU per sample frame)"
    others = [t for t in trials if t not in tied]
    if others:
        why += "; " + ", ".join(_other(t) for t in others)
    return best, why


def _score(trial: Trial) -> float:
    return trial.scores.score if trial.scores is not None else 0.0


def _other(trial: Trial) -> str:
    if trial.scores is None:
        return f"{trial.label} not run"
    state = "plausible" if trial.scores.plausible else "not plausible"
    return f"{trial.label} {trial.scores.score:.2f} ({state}, reach {trial.scores.reach_m:.1f} m)"


def _since(t0: float) -> float:
    return time.perf_counter() - t0


def drive_self_check(
    recording: Recording, topic: str, config: ReprocessConfig, camera: CameraModel
) -> SelfCheck | str:
    """Run the self-check on a drive when its backend is ``auto``; else say why it is skipped.

    The sample is read from the open recording before the drive's one pass: the frames' log
    times first (undecoded), then each run through the one frame reader
    (:func:`~superlane_tools.recording.camera_frames.camera_frames`: video from the keyframe
    before it); each frame is decoded once. What the sample's reading skips (corrupt messages)
    is not counted: a recording reports what its latest pass skipped, and the drive's pass
    reads every sampled frame again.

    Args:
        recording: The open recording.
        topic: Its camera topic.
        config: The run's configuration.
        camera: The drive's camera.

    Returns:
        The self-check, or the line saying it was skipped (an explicit backend or model).
    """
    from superlane_tools.scene.backends import auto_candidates

    seg = config.segmentation
    if seg.backend != "auto" or seg.model:
        chosen = f"--model {seg.model}" if seg.model else f"--backend {seg.backend}"
        return f"segmentation self-check skipped: backend chosen explicitly ({chosen})"
    c0 = time.process_time()
    times = [raw.log_time_ns for raw in recording.raw_messages(topics=[topic])]
    runs = _read_sample(recording, topic, times, seg.process_width)
    if not runs:
        return "segmentation self-check skipped: no camera frames to sample"
    check = self_check(config, camera, runs, auto_candidates(), _card_pick)
    return replace(check, cpu_s=time.process_time() - c0)  # reading and decoding included


def _read_sample(
    recording: Recording, topic: str, times: Sequence[int], process_width: int
) -> list[list[tuple[int, Any]]]:
    """Read each sampled run and decode its frames once: ``(log time, (size, image))``."""
    from superlane_tools.recording.camera_frames import camera_frames

    runs = []
    for start in sample_starts(len(times)):
        stop = min(start + CLIP_FRAMES, len(times))
        frames = camera_frames(recording, topic, times[start:stop], process_width)
        run = [
            (frame.log_time_ns, (frame.size, frame.image))
            for frame in frames
            if frame.image is not None  # a corrupt frame: the pass counts it
        ]
        if run:
            runs.append(run)
    return runs


def _card_pick() -> tuple[str, str]:
    from superlane_tools.scene.backends import auto_backend
    from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL

    name, _ = auto_backend(None)
    return name, DEFAULT_SEGMENTATION_MODEL if name == "onnx" else ""


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
    c0 = time.process_time()
    check = self_check(cfg, camera, runs, auto_candidates(), _card_pick)
    return replace(check, cpu_s=time.process_time() - c0)
