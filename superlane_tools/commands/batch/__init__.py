"""Batch reprocessing of many recordings: local process pool or Ray, idempotent, resumable."""

from superlane_tools.commands.batch.engine import (
    BatchEngine,
    Job,
    JobOutcome,
    JobStatus,
    OnDone,
)
from superlane_tools.commands.batch.errors import BatchError, EngineUnavailableError
from superlane_tools.commands.batch.jobs import JobKind, JobResult, load_config_file
from superlane_tools.commands.batch.kinds import default_kind, job_kind, reprocess_available
from superlane_tools.commands.batch.local import LocalEngine, default_workers
from superlane_tools.commands.batch.manifest import (
    BatchEntry,
    expand_inputs,
    find_recordings,
    read_manifest,
    recording_id,
)
from superlane_tools.commands.batch.params import BatchParams, BatchProgress, BatchReport
from superlane_tools.commands.batch.ray_engine import RayEngine
from superlane_tools.commands.batch.root import clean_stale_tmp
from superlane_tools.commands.batch.run import run_batch
from superlane_tools.commands.batch.status import STATUS_FILE, read_status
from superlane_tools.commands.batch.summary import write_summary
from superlane_tools.commands.batch.worker import MARKER, read_marker

__all__ = [
    "MARKER",
    "STATUS_FILE",
    "BatchEngine",
    "BatchEntry",
    "BatchError",
    "BatchParams",
    "BatchProgress",
    "BatchReport",
    "EngineUnavailableError",
    "Job",
    "JobKind",
    "JobOutcome",
    "JobResult",
    "JobStatus",
    "LocalEngine",
    "OnDone",
    "RayEngine",
    "clean_stale_tmp",
    "default_kind",
    "default_workers",
    "expand_inputs",
    "find_recordings",
    "job_kind",
    "load_config_file",
    "read_manifest",
    "read_marker",
    "read_status",
    "recording_id",
    "reprocess_available",
    "run_batch",
    "write_summary",
]
