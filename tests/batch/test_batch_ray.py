"""The Ray engine against a real local Ray instance (started once; startup costs seconds)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pandas as pd
import pytest

from superlane_tools.pipeline.batch import BatchParams, RayEngine, expand_inputs, run_batch

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ray_engine_matches_local(
    tmp_path: Path, make_drives: Callable[..., list[Path]], local_ray: None
) -> None:
    make_drives(4, 1)
    entries = expand_inputs([tmp_path / "recs"])
    config = {"frame_format": "none"}
    local = run_batch(entries, BatchParams(tmp_path / "local", "extract", workers=2, config=config))
    params = BatchParams(tmp_path / "ray", "extract", engine="ray", workers=2, config=config)
    report = run_batch(entries, params)
    assert report.engine == "ray"
    assert report.workers == 2
    assert report.counts == local.counts == {"ok": 4, "partial": 0, "failed": 1, "skipped": 0}
    assert report.failures == local.failures
    a = pd.read_parquet(tmp_path / "local" / "batch_status.parquet")
    b = pd.read_parquet(tmp_path / "ray" / "batch_status.parquet")
    assert list(a["recording_id"]) == list(b["recording_id"])
    assert list(a["key"]) == list(b["key"])
    assert set(b["engine"]) == {"ray"}
    for rid in a.loc[a["status"] == "ok", "recording_id"]:
        left = pd.read_parquet(tmp_path / "local" / rid / "can_raw.parquet")
        right = pd.read_parquet(tmp_path / "ray" / rid / "can_raw.parquet")
        pd.testing.assert_frame_equal(left, right)
    # a second run on the joined instance skips everything and starts no actors
    again = run_batch([e for e in entries if "drive" in e.path.name], params)
    assert again.counts["skipped"] == 4
    assert ray.is_initialized()  # the engine leaves an instance it did not start running


def test_ray_engine_outside_context_is_a_bug() -> None:
    engine = RayEngine("extract", {})
    with pytest.raises(RuntimeError, match="outside its context"):
        engine.run([], lambda outcome: None)
