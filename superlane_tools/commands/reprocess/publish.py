"""``slt reprocess`` into a run folder that appears whole or not at all."""

from __future__ import annotations

import os
import subprocess

from superlane_tools.commands.reprocess.result import ReprocessResult
from superlane_tools.commands.reprocess.run import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.reprocess_pass import Phase
from superlane_tools.records import Progress


def reprocess_run(
    recording_path: str | os.PathLike[str],
    target: str | os.PathLike[str],
    config: ReprocessConfig,
    progress: Progress | None = None,
    command: str = "",
    with_signals: bool = False,
    compiler: subprocess.Popen[bytes] | None = None,
    phase: Phase | None = None,
) -> ReprocessResult:
    """Reprocess into a staging folder beside ``target``, then publish it there in one step.

    Args:
        recording_path: The recording.
        target: The run folder (replaced only when the run succeeds).
        config: Configuration.
        progress: Called as ``progress(frames_done, frames_total_or_None)``.
        command: Command line for the provenance.
        with_signals: Also add the decoded CAN signals and truth curves to the annotations.
        compiler: The lane-fit kernels' compiler, started early by the caller
            (:func:`~superlane_tools.lanes.kernel_cache.start_compiling`), or None.
        phase: Called with a label as each phase of the run starts.

    Raises:
        OutputError: If ``target`` is a file or a foreign folder, or cannot be written.
    """
    from superlane_tools.lanes.kernel_cache import warm_up_in_background
    from superlane_tools.reporting.run_folder import staged_run

    warm_up_in_background(config.fit_params.backend, compiler)
    with staged_run(target) as stage:  # the whole run appears at once, or not at all
        return reprocess(
            recording_path, stage, config, progress, command, with_signals=with_signals, phase=phase
        )
