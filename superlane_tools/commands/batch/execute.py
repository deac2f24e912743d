"""Running a batch's planned jobs on an engine: retry rounds, each attempt recorded as it ends."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import partial

from superlane_tools.commands.batch.engine import BatchEngine, Job, JobOutcome, OnDone
from superlane_tools.commands.batch.params import Tally
from superlane_tools.commands.batch.plan import PlannedJob
from superlane_tools.commands.batch.status import RowContext, StatusTable


def execute_plan(
    planned: Sequence[PlannedJob],
    engine: BatchEngine,
    retries: int,
    status: StatusTable,
    rows: RowContext,
    tally: Tally,
) -> int:
    """Run the planned jobs on ``engine``; retry failing ones ``retries`` times.

    The engine is entered only when there are jobs; each round of retries reuses its warm
    workers. Every attempt is written to the status table as it ends.

    Args:
        planned: The jobs to run (:func:`~superlane_tools.commands.batch.plan.plan_jobs`).
        engine: The engine, not yet entered.
        retries: Extra attempts for a failing job before it is counted as failed.
        status: The root's status table.
        rows: What every status row shares.
        tally: Counts and failures so far; told each attempt (phase ``running``).

    Returns:
        The engine's workers (0 when there was nothing to run).
    """
    if not planned:
        return 0
    attempts = _Attempts({p.job.recording_id: p for p in planned}, retries, status, rows, tally)
    with engine:
        pending = [p.job for p in planned]
        for attempt in range(1, retries + 2):
            retry: list[Job] = []
            if pending:
                engine.run(pending, attempts.on_done(attempt, retry, engine.name))
            pending = retry
        return engine.workers


@dataclass
class _Attempts:
    """Records each finished attempt: its status row, the tally, the progress.

    A failed attempt before the last is queued for the next round instead of being counted.
    """

    planned: dict[str, PlannedJob]
    retries: int
    status: StatusTable
    rows: RowContext
    tally: Tally
    finished: int = 0

    def on_done(self, attempt: int, retry: list[Job], engine: str) -> OnDone:
        """Return the engine's callback for the round of attempt ``attempt``."""
        return partial(self._done, attempt, retry, engine)

    def _done(self, attempt: int, retry: list[Job], engine: str, outcome: JobOutcome) -> None:
        plan = self.planned[outcome.recording_id]
        if outcome.status == "failed" and attempt <= self.retries:
            retry.append(replace(plan.job, attempt=attempt + 1))
        else:
            self.finished += 1
            self.tally.count(outcome.status, outcome.recording_id, outcome.error)
        row = self.rows.row(
            plan.entry,
            outcome.recording_id,
            plan.file,
            outcome.status,
            outcome.status,
            outcome.error,
            outcome.key,
            engine,
            timings=outcome.timings,
            outputs=outcome.outputs,
            frames=outcome.frames,
            attempts=attempt,
            host=outcome.host,
            ray_node=outcome.node,
        )
        self.status.update(row)
        self.tally.tell("running", self.finished, len(self.planned), outcome)
