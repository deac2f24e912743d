"""``slt batch``'s entry: the options as typed, the recordings listed, the batch run."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.commands.batch.jobs import load_config_file
from superlane_tools.commands.batch.kinds import default_kind
from superlane_tools.commands.batch.manifest import expand_inputs, read_manifest
from superlane_tools.commands.batch.params import BatchParams, BatchProgress, BatchReport
from superlane_tools.commands.batch.run import run_batch
from superlane_tools.errors import UsageError

Ticker = Callable[[int, str], AbstractContextManager[Callable[[BatchProgress], None]]]
"""Opens the cli's progress display, given the recordings and the job kind; yields its tick."""


@dataclass(frozen=True)
class BatchOptions:
    """What ``slt batch`` was asked, as typed (see its options)."""

    inputs: list[Path] = field(default_factory=list)
    manifest: Path | None = None
    out: Path = Path("runs")
    engine: str = "local"
    workers: int | None = None
    ray_address: str | None = None
    config: Path | None = None
    retries: int = 1
    force: bool = False
    job: str | None = None
    command: str = ""


def run(options: BatchOptions, ticker: Ticker) -> BatchReport:
    """List the recordings, then run the batch (each recording's progress goes to the tick).

    Raises:
        UsageError: If both or neither of recordings and a manifest are given.
    """
    o = options
    if bool(o.inputs) == (o.manifest is not None):
        raise UsageError("give recordings/folders or --manifest FILE (one of the two)")
    entries = read_manifest(o.manifest) if o.manifest is not None else expand_inputs(o.inputs)
    params = BatchParams(
        root=o.out,
        kind=o.job or default_kind(),
        engine=o.engine.lower(),
        workers=o.workers,
        retries=o.retries,
        force=o.force,
        config=load_config_file(o.config) if o.config is not None else {},
        ray_address=o.ray_address,
        command=o.command,
    )
    with ticker(len(entries), params.kind) as tick:
        return run_batch(entries, params, progress=tick)
