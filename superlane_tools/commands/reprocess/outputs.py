"""What ``slt reprocess`` writes: its provenance, the frame sinks, then tables, plots, report."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.examples import example_indices
from superlane_tools.drive.finalize import DerivedTables, report_sections
from superlane_tools.drive.loop import FrameSink
from superlane_tools.drive.reprocess_pass import DriveOutcome, PassSetup
from superlane_tools.drive.run_facts import run_header
from superlane_tools.drive.selfcheck import SelfCheck
from superlane_tools.drive.sinks import AnnotationSink, ExampleSink, FrameTablesSink, VideoSink
from superlane_tools.drive.stages import FrameStages
from superlane_tools.reporting import Provenance, input_identity, write_table
from superlane_tools.reporting.drive_sections import ReportFacts
from superlane_tools.reporting.layout import RunLayout, checked_table, tables_of
from superlane_tools.reporting.plots import ExampleFrame
from superlane_tools.reporting.report import write_report

if TYPE_CHECKING:
    import pyarrow as pa

    from superlane_tools.corridor import TimeSegment


def run_provenance(
    src: Path,
    dbc_paths: Sequence[Path],
    config: ReprocessConfig,
    setup: PassSetup,
    segments: Sequence[TimeSegment] | None,
    command: str,
) -> Provenance:
    """Return the provenance of every output: inputs, the configuration and what it resolved to.

    Args:
        src: The recording.
        dbc_paths: The DBC files used.
        config: The configuration.
        setup: What the drive resolved to (without a camera: the configuration alone).
        segments: KPI sequences given by the caller (recorded when given, with a camera).
        command: Command line (default: ``reprocess('<name>')``).
    """
    inputs = (input_identity(src), *(input_identity(p) for p in dbc_paths))
    command = command or f"reprocess({src.name!r})"
    topics, camera, stages, check = setup.topics, setup.camera, setup.stages, setup.check
    if camera is None or stages is None:
        return Provenance(command=command, inputs=inputs, config=config.to_dict())
    config_data = config.to_dict()
    config_data["resolved"] = {
        "streams": topics.streams._asdict(),
        "camera": camera.to_dict(),
        "segmentation_backend": stages.backend_name,
        "corridor_unavailable": stages.corridor_unavailable,
        "segmentation_self_check": check.to_dict() if isinstance(check, SelfCheck) else check,
    }
    if segments is not None:
        config_data["resolved"]["segments"] = [s._asdict() for s in segments]
    return Provenance(command=command, inputs=inputs, config=config_data, models=stages.models)


class RunOutputs:
    """The files of one run: the frame sinks, opened once the drive is resolved, then the rest.

    :meth:`open` is the :data:`~superlane_tools.drive.reprocess_pass.SinkOpener` of the pass;
    :meth:`write` writes the derived tables, the plots and the report of its outcome.
    """

    def __init__(
        self,
        out: Path,
        config: ReprocessConfig,
        inputs: tuple[Path, Sequence[Path]],
        segments: Sequence[TimeSegment] | None,
        command: str,
    ) -> None:
        self.out, self.config, self.inputs = out, config, inputs
        self.segments, self.command = segments, command
        self.sinks: PassSinks | None = None
        self.provenance: Provenance | None = None

    def _provenance(self, setup: PassSetup) -> Provenance:
        src, dbc_paths = self.inputs
        return run_provenance(src, dbc_paths, self.config, setup, self.segments, self.command)

    def open(self, setup: PassSetup) -> list[FrameSink]:
        """Open the frame sinks of a resolved drive with a camera."""
        assert setup.stages is not None
        self.provenance = self._provenance(setup)
        self.out.mkdir(parents=True, exist_ok=True)
        self.sinks = open_sinks(
            self.out, self.config, setup.stages, setup.topics.frames, self.provenance, setup.total
        )
        return self.sinks.all()

    def write(self, outcome: DriveOutcome) -> list[Path]:
        """Write the derived tables, the plots and the report; return every file written."""
        provenance = self.provenance or self._provenance(outcome.setup)
        written, rendered = self.sinks.written(outcome.files) if self.sinks else ([], [])
        self.out.mkdir(parents=True, exist_ok=True)
        written += write_outputs(
            self.out, outcome.derived, provenance, self.config, [], outcome.facts, rendered
        )
        return written


class PassSinks(NamedTuple):
    """The sinks of one pass: those that write outputs, and the example plots (for the report).

    Attributes:
        outputs: The per-frame tables, then the annotations and the overlay video when enabled.
        examples: The example plots drawn during the pass.
    """

    outputs: tuple[FrameSink, ...]
    examples: ExampleSink

    def all(self) -> list[FrameSink]:
        """Return every sink, in the order :func:`~superlane_tools.drive.run_frames` takes."""
        return [*self.outputs, self.examples]

    def written(self, files: Sequence[Sequence[Path]]) -> tuple[list[Path], list[Path]]:
        """Return the files the output sinks wrote, and the example plots, of a pass.

        ``files``: per sink, in :meth:`all`'s order, the files its ``close`` returned.
        """
        n = len(self.outputs)
        return [p for group in files[:n] for p in group], list(files[n])


def open_sinks(
    out: Path,
    config: ReprocessConfig,
    stages: FrameStages,
    camera_topic: str,
    provenance: Provenance,
    total: int | None,
) -> PassSinks:
    """Open the sinks of a pass into ``out`` (a sink that fails to open closes the others).

    Args:
        out: The run folder.
        config: ``output.*`` says which sinks, ``corridor.mean_frames`` the tables' mean.
        stages: The stages (the corridor network's status).
        camera_topic: The image topic the annotations belong to.
        provenance: Provenance of the tables.
        total: Frames in the recording when known (spreads the example frames).
    """
    layout = RunLayout(out)
    out_cfg = config.output
    opened: list[FrameSink] = []
    try:
        tables = FrameTablesSink(
            layout.streamed(), provenance, stages.corridor_unavailable, config.corridor.mean_frames
        )
        opened.append(tables)
        if out_cfg.annotations:
            opened.append(AnnotationSink(layout.annotations, camera_topic))
        if out_cfg.video:
            opened.append(VideoSink(layout.overlay, out_cfg.video_fps or 15.0))
        indices = example_indices(total, out_cfg.plots and out_cfg.example_frames)
        return PassSinks(tuple(opened), ExampleSink(layout.plots, indices))
    except BaseException:
        for sink in opened:
            sink.close(False)
        raise


def table_files(out: Path, result: DerivedTables) -> dict[Path, pa.Table]:
    """Return output path -> table of the derived tables (``result.<name>`` of each spec).

    Each table is checked against its :class:`~superlane_tools.reporting.layout.TableSpec`.

    Raises:
        ~superlane_tools.reporting.layout.SchemaMismatchError: If a builder's table
            disagrees with its declared schema.
    """
    return {
        out / spec.file: checked_table(spec, getattr(result, spec.name))
        for spec in tables_of("derived").values()
    }


def write_outputs(
    out: Path,
    result: DerivedTables,
    provenance: Provenance,
    config: ReprocessConfig,
    examples: Sequence[ExampleFrame],
    report: ReportFacts,
    rendered: Sequence[Path] = (),
) -> list[Path]:
    """Write the derived tables, the plots and the report; return the files written.

    ``rendered``: example plots already written (during the pass), listed after the plots
    drawn here, as :func:`~superlane_tools.reporting.plots.plot_all` orders its own examples.
    """
    layout = RunLayout(out)
    report = replace(
        report,
        header=run_header(provenance),
        input_bytes=provenance.inputs[0].size_bytes if provenance.inputs else 0,
    )
    written = [write_table(t, path, provenance) for path, t in table_files(out, result).items()]
    images: list[str] = []
    if config.output.plots:
        from superlane_tools.reporting.plots import plot_all

        pngs = plot_all(result.curvature, result.availability_frames, examples, layout.plots)
        pngs += rendered
        written += pngs
        images = [p.relative_to(out).as_posix() for p in pngs]
    written += write_report(
        layout.report,
        f"slt reprocess: {report.recording.name}",
        report_sections(config, report, result, images),
        preamble=report.header,
    )
    return written


def add_signal_channels(out: Path, result: DerivedTables) -> dict[str, int] | None:
    """Add the decoded CAN signals and truth curves to the run's annotations (None: no file)."""
    from superlane_tools.reporting.annotations import add_signals

    annotations = RunLayout(out).annotations
    if not annotations.is_file():
        return None
    return add_signals(annotations, result.can_signals, result.curvature)
