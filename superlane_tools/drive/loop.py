"""The frame loop: one pass over a recording, every camera frame through the stages into sinks.

:func:`run_frames` reads the recording once, in log-time order, through the one streaming pass
(:func:`~superlane_tools.reporting.message_pass.stream_messages`, which ``slt extract`` uses
too). The camera topic is routed to the stage pipeline: each image message goes to a worker
thread (:meth:`FrameStages.prepare`: decode, segmentation, points, corridor network, Hough), then
in frame order through :meth:`FrameStages.finish` (the warm-started fit and the corridor mean);
the finished frame goes to the drive's typed record and to every :class:`FrameSink` (the
per-frame tables, annotations, overlay video, example plots). The CAN, IMU and GNSS topics are
routed to their collectors. A new per-frame output is a new sink, never a copy of this loop.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple, Protocol

from superlane_tools.can.collect import CanFrames
from superlane_tools.drive.config import TopicsConfig
from superlane_tools.drive.record import DriveFrames, DriveFramesBuilder
from superlane_tools.drive.signals import ImuSamples
from superlane_tools.drive.stages import Finished, FrameStages, Prepared
from superlane_tools.recording import Streams, read_with_video, select_one_each, topics_of_type
from superlane_tools.records import Message, Progress
from superlane_tools.reporting.gnss_fixes import GnssCollector, GnssFixes
from superlane_tools.reporting.message_pass import MessageTaker, stream_messages

CAN_TYPE, IMU_TYPE = "can_msgs/msg/Frame", "sensor_msgs/msg/Imu"
"""Every topic of these types is read unless ``topics.can`` / ``topics.imu`` names one."""


class FrameSink(Protocol):
    """Takes every finished frame in frame order; writes its output when closed.

    ``run_frames`` calls :meth:`add` once per frame and :meth:`close` once at the end: with
    ``ok=True`` after the last frame, with ``ok=False`` when the pass failed (discard partial
    output). ``close`` returns the files written (none when discarded). The messages
    themselves go to ``reporting.message_pass.MessageSink`` s (``slt extract``'s tables).
    """

    def add(self, done: Finished) -> None:
        """Take one finished frame."""

    def close(self, ok: bool) -> list[Path]:
        """Finish (``ok``) or discard the output; return the files written."""


class DriveTopics(NamedTuple):
    """The topics one pass reads.

    Attributes:
        streams: One topic per stream kind (frames "" without a camera) and notes on the choice.
        can: Every CAN bus read (one when ``topics.can`` names it).
        imu: Every IMU topic read (one when ``topics.imu`` names it).
    """

    streams: Streams
    can: frozenset[str]
    imu: frozenset[str]

    @property
    def frames(self) -> str:
        """The camera topic ("" when the recording has none)."""
        return self.streams.frames

    def wanted(self) -> list[str]:
        """Return the topics to read, camera first."""
        s = self.streams
        return [t for t in (s.frames, s.gnss, *sorted(self.can), *sorted(self.imu)) if t]


def drive_topics(recording: Any, topics: TopicsConfig) -> DriveTopics:
    """Pick the camera, CameraInfo, CAN, GNSS and IMU topics of a recording."""
    from dataclasses import asdict

    listed = recording.topics()
    streams = select_one_each(listed, asdict(topics))
    can = {streams.can} if topics.can else topics_of_type(listed, CAN_TYPE)
    imu = {topics.imu} if topics.imu else topics_of_type(listed, IMU_TYPE)
    return DriveTopics(streams, frozenset(can), frozenset(imu))


@dataclass(frozen=True)
class DrivePass:
    """What one pass over a drive gathered.

    Attributes:
        frames: The drive's per-frame record (empty without a camera).
        can: The CAN frames of every bus read.
        imu: The IMU samples.
        gnss: The GNSS fixes.
        files: Per sink, in the order given, the files its ``close`` returned.
        failed: ``frame <index>: <error>`` for each frame whose image could not be used.
        span_ns: Without a camera: first and last log time of the messages read (None when
            none was read, or with a camera).
    """

    frames: DriveFrames
    can: CanFrames
    imu: ImuSamples
    gnss: GnssFixes
    files: tuple[tuple[Path, ...], ...]
    failed: tuple[str, ...]
    span_ns: tuple[int, int] | None


def frame_total(recording: Any, topic: str) -> int | None:
    """Return the number of messages on ``topic`` when the recording's summary knows it."""
    return next((t.message_count for t in recording.topics() if t.topic == topic), None)


def run_frames(
    recording: Any,
    topics: DriveTopics,
    stages: FrameStages | None,
    sinks: Sequence[FrameSink],
    workers: int = 1,
    progress: Progress | None = None,
) -> DrivePass:
    """Read a recording once: frames through the stages into the sinks, signals collected.

    Args:
        recording: An open recording (:func:`~superlane_tools.recording.open_recording`).
        topics: The topics to read (:func:`drive_topics`).
        stages: The per-frame stages (None: no camera; only CAN, IMU and GNSS are collected).
        sinks: Take every finished frame; closed at the end (``ok=False`` on an error).
        workers: Threads of the frame-local stages.
        progress: Called as ``progress(frames_done, frames_total_or_None)``.

    Returns:
        The drive's record, its signals, the sinks' files, the failed frames and the time span.
    """
    loop = _Loop(topics, stages, sinks, workers, progress)
    camera = stages is not None and bool(topics.frames)
    if camera:  # video decoded in the pass; signals only: messages as read
        loop.total = frame_total(recording, topics.frames)
        messages = read_with_video(recording, topics.wanted())
    else:
        messages = recording.messages(topics=topics.wanted())
    read = stream_messages(messages, loop.route(camera), [loop])
    return loop.result(None if camera else read.span_ns)


class _Loop:
    """The stage pipeline of one pass (the camera topic's taker) and the collected signals.

    Frames go to the pool as they are read, a bounded backlog is finished in frame order;
    :meth:`close` finishes the rest, then closes the frame sinks.
    """

    def __init__(
        self,
        topics: DriveTopics,
        stages: FrameStages | None,
        sinks: Sequence[FrameSink],
        workers: int,
        progress: Progress | None,
    ) -> None:
        self.topics, self.stages, self.sinks = topics, stages, sinks
        self.workers, self.progress = workers, progress
        self.total: int | None = None
        self.record = DriveFramesBuilder(stages.max_slope if stages is not None else 0.0)
        self.can, self.imu, self.gnss = CanFrames(), ImuSamples(), GnssCollector()
        self.failed: list[str] = []
        self.done = 0
        self.index = 0
        self.pending: deque[Future[Prepared]] = deque()
        self.pool: ThreadPoolExecutor | None = None
        self.files: tuple[tuple[Path, ...], ...] = ()

    def route(self, camera: bool) -> dict[str, MessageTaker]:
        """Return topic -> taker: the camera to the stages (with ``camera``), signals collected."""
        route: dict[str, MessageTaker] = {self.topics.streams.gnss: self.gnss}
        route.update(dict.fromkeys(self.topics.imu, self.imu))
        route.update(dict.fromkeys(self.topics.can, self.can))  # a topic in two: CAN first
        route.pop("", None)
        if camera:
            route[self.topics.frames] = self
        return route

    def add(self, msg: Message) -> None:
        """Send one frame through the stages (a bounded backlog on the pool)."""
        stages = self.stages
        assert stages is not None
        if self.pool is None:
            self.pool = ThreadPoolExecutor(self.workers, "slt-reprocess")
        self.pending.append(self.pool.submit(stages.prepare, self.index, msg))
        self.index += 1
        for prep in stages.due(self.pending, self.workers):
            self.finish(prep)

    def close(self, ok: bool) -> list[Path]:
        """Finish the pending frames (``ok``), stop the pool and close the frame sinks.

        Returns:
            Every frame sink's files (per sink, in the sinks' order, in :attr:`files`).
        """
        try:
            if ok:
                while self.pending:
                    self.finish(self.pending.popleft().result())
        except BaseException:
            ok = False
            raise
        finally:
            if self.pool is not None:
                self.pool.shutdown(wait=True)
            if not ok:
                for sink in self.sinks:
                    sink.close(False)
        if not ok:
            return []
        self.files = tuple(tuple(sink.close(True)) for sink in self.sinks)
        return [path for files in self.files for path in files]

    def finish(self, prep: Prepared) -> None:
        """Run the sequential stages on one frame and hand it to the record and the sinks."""
        assert self.stages is not None
        done = self.stages.finish(prep)
        self.record.add(done)
        for sink in self.sinks:
            sink.add(done)
        if prep.error:
            self.failed.append(f"frame {prep.index}: {prep.error}")
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total)

    def result(self, span: tuple[int, int] | None) -> DrivePass:
        """Return what the pass gathered, with the sinks' files and the messages' span."""
        frames = self.record.frames()
        fixes = self.gnss.fixes()
        return DrivePass(frames, self.can, self.imu, fixes, self.files, tuple(self.failed), span)
