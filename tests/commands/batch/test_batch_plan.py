"""The three steps of ``run_batch``: ``plan_jobs``, ``execute_plan`` (retries), ``summarise``."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import Self

import pytest

from superlane_tools.commands.batch import (
    MARKER,
    BatchEntry,
    BatchParams,
    BatchProgress,
    Job,
    JobOutcome,
    OnDone,
    read_status,
)
from superlane_tools.commands.batch.engine import TMP_DIR
from superlane_tools.commands.batch.execute import execute_plan
from superlane_tools.commands.batch.params import Tally
from superlane_tools.commands.batch.plan import PlannedJob, config_sha256, plan_jobs
from superlane_tools.commands.batch.run import summarise
from superlane_tools.commands.batch.status import RowContext, StatusTable

CONFIG = {"frame_format": "none"}


def _context(root: Path) -> tuple[BatchParams, StatusTable, RowContext]:
    params = BatchParams(root, "extract", config=CONFIG)
    root.mkdir(parents=True, exist_ok=True)
    status = StatusTable(root, "test", {"job": "extract", **CONFIG})
    return params, status, RowContext("extract", {}, config_sha256(CONFIG))


def test_plan_counts_unreadable_skips_finished_and_runs_duplicates_once(
    tmp_path: Path, write_drive: Callable[..., Path]
) -> None:
    drive = write_drive(tmp_path / "drive.mcap")
    other = write_drive(tmp_path / "other.mcap", seed=1)
    entries = [
        BatchEntry(drive),
        BatchEntry(drive),
        BatchEntry(other),
        BatchEntry(tmp_path / "gone"),
    ]
    params, status, rows = _context(tmp_path / "out")
    seen: list[BatchProgress] = []
    tally = Tally(seen.append)
    planned = plan_jobs(entries, params, True, status, rows, tally)
    assert [p.job.recording for p in planned] == [drive, other]  # the duplicate runs once
    assert tally.counts == {"ok": 0, "partial": 0, "failed": 1, "skipped": 0}
    ((gone_id, reason),) = tally.failures.items()
    assert reason.startswith(f"cannot read {tmp_path / 'gone'}")
    assert [(p.phase, p.done, p.total) for p in seen] == [("hashing", n, 4) for n in (1, 2, 3, 4)]
    table = read_status(tmp_path / "out")  # written once planning ends
    assert table.set_index("recording_id").loc[gone_id, "status"] == "failed"

    done = planned[0].job  # an earlier run finished the drive with this key: skipped
    done.out_dir.mkdir()
    marker = {"key": done.key, "status": "partial", "note": "lost 2 frames", "frames": 7}
    (done.out_dir / MARKER).write_text(json.dumps(marker), encoding="utf-8")
    again = Tally()
    replanned = plan_jobs(entries[:3], params, True, status, rows, again)
    assert [p.job.recording for p in replanned] == [other]
    assert again.counts["skipped"] == 1
    row = read_status(tmp_path / "out").set_index("recording_id").loc[done.recording_id]
    assert (row["status"], row["result"], row["error"], row["frames"]) == (
        "skipped",
        "partial",
        "lost 2 frames",
        7,
    )
    forced = BatchParams(params.root, "extract", config=CONFIG, force=True)
    assert len(plan_jobs(entries[:3], forced, True, status, rows, Tally())) == 2


class _ScriptedEngine:
    """A batch engine of this test: each job's attempts end as ``script`` says, in order."""

    name = "scripted"

    def __init__(self, script: dict[str, list[str]]) -> None:
        self.script = script
        self.rounds: list[list[tuple[str, int]]] = []
        self.entered = 0

    @property
    def workers(self) -> int:
        return 3

    @property
    def log(self) -> Path | None:
        return None

    def __enter__(self) -> Self:
        self.entered += 1
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        return None

    def run(self, jobs: Sequence[Job], on_done: OnDone) -> None:
        self.rounds.append([(j.recording_id, j.attempt) for j in jobs])
        for job in jobs:
            status = self.script[job.recording_id][job.attempt - 1]
            error = "boom" if status == "failed" else ""
            on_done(JobOutcome(job.recording_id, job.key, status, error, attempt=job.attempt))  # type: ignore[arg-type]


def test_execute_retries_failed_jobs_then_counts_them(
    tmp_path: Path, write_drive: Callable[..., Path]
) -> None:
    drives = [write_drive(tmp_path / f"d{k}.mcap", seed=k) for k in range(3)]
    params, status, rows = _context(tmp_path / "out")
    planned = plan_jobs([BatchEntry(d) for d in drives], params, True, status, rows, Tally())
    ids = [p.job.recording_id for p in planned]
    script = {ids[0]: ["ok"], ids[1]: ["failed", "partial"], ids[2]: ["failed", "failed"]}
    engine = _ScriptedEngine(script)
    seen: list[BatchProgress] = []
    tally = Tally(seen.append)
    assert execute_plan(planned, engine, 1, status, rows, tally) == 3
    assert engine.rounds == [[(i, 1) for i in ids], [(ids[1], 2), (ids[2], 2)]]
    assert tally.counts == {"ok": 1, "partial": 1, "failed": 1, "skipped": 0}
    assert tally.failures == {ids[2]: "boom"}
    assert [(p.done, p.total) for p in seen] == [(1, 3), (1, 3), (1, 3), (2, 3), (3, 3)]
    table = read_status(tmp_path / "out").set_index("recording_id")
    assert list(table.loc[ids, "attempts"]) == [1, 2, 2]
    assert list(table.loc[ids, "engine"]) == ["scripted"] * 3

    idle = _ScriptedEngine({})
    assert execute_plan([], idle, 1, status, rows, Tally()) == 0
    assert idle.entered == 0  # no jobs: the engine is never started


@pytest.mark.parametrize("summary", [True, False])
def test_summarise_clears_the_workers_folder(tmp_path: Path, summary: bool) -> None:
    params, status, _ = _context(tmp_path / "out")
    status.write()
    (params.root / TMP_DIR).mkdir()
    asked = BatchParams(params.root, "extract", config=CONFIG, summary=summary)
    written = summarise(params.root, asked)
    assert not (params.root / TMP_DIR).exists()
    assert bool(written) == summary
    assert all(p.parent.name == "summary" for p in written)


def test_planned_jobs_keep_their_entry(tmp_path: Path, write_drive: Callable[..., Path]) -> None:
    drive = write_drive(tmp_path / "drive.mcap")
    entry = BatchEntry(drive, category="highway", start_s=0.2, end_s=0.6)
    params, status, rows = _context(tmp_path / "out")
    (planned,) = plan_jobs([entry], params, True, status, rows, Tally())
    assert isinstance(planned, PlannedJob)
    assert planned.entry == entry
    assert dict(planned.job.config) == {**CONFIG, "start_s": 0.2, "end_s": 0.6}
