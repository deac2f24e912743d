"""`run_batch` with the local engine on real recordings: status, retries, idempotency, summary."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from superlane_tools.commands.batch import (
    MARKER,
    BatchEntry,
    BatchError,
    BatchParams,
    BatchProgress,
    clean_stale_tmp,
    expand_inputs,
    read_status,
    run_batch,
    write_summary,
)
from superlane_tools.commands.batch.root import root_lock
from superlane_tools.commands.batch.status import StatusRow, StatusTable
from superlane_tools.reporting import Provenance, read_provenance, write_table
from superlane_tools.reporting.layout import (
    BATCH_STATUS_TABLE,
    SummaryLayout,
    checked_table,
    tables_of,
)
from superlane_tools.reporting.run_folder import write_run_manifest

EXTRACT = {"frame_format": "none"}


def _params(root: Path, **kw: object) -> BatchParams:
    base: dict[str, object] = {"root": root, "kind": "extract", "workers": 2, "config": EXTRACT}
    base.update(kw)
    return BatchParams(**base)  # type: ignore[arg-type]


@pytest.mark.slow
def test_batch_ok_failed_and_idempotent(
    tmp_path: Path, make_drives: Callable[..., list[Path]]
) -> None:
    make_drives(3, 2)
    root = tmp_path / "out"
    entries = expand_inputs([tmp_path / "recs"])
    seen: list[BatchProgress] = []
    report = run_batch(entries, _params(root), progress=seen.append)
    assert report.counts == {"ok": 3, "partial": 0, "failed": 2, "skipped": 0}, report.failures
    assert report.failed_fraction == pytest.approx(0.4)
    reasons = dict(report.failures)
    assert len(reasons) == 2
    assert all("corrupt_" in rid for rid in reasons)
    assert any("is not a recording" in r for r in reasons.values())
    assert seen[-1].phase == "running"
    assert seen[-1].done == 5

    status = read_status(root)
    assert len(status) == 5
    assert status["recording_id"].is_unique
    failed = status[status["status"] == "failed"]
    assert (failed["attempts"] == 2).all()  # retried once
    assert (failed["error"] != "").all()
    ok = status[status["status"] == "ok"]
    assert (ok["frames"] == 10).all()
    assert (ok["total_s"] > 0).all()
    assert ok["content_hash"].str.fullmatch("blake3:[0-9a-f]{64}").all()
    for rid in ok["recording_id"]:
        marker = json.loads((root / rid / MARKER).read_text())
        assert marker["key"] == status.set_index("recording_id").loc[rid, "key"]
        assert len(pd.read_parquet(root / rid / "frames.parquet")) == 10
    assert not (root / ".tmp").exists()
    for name in ("report.md", "report.html", "fleet_status.parquet"):
        assert (root / "summary" / name).is_file()
    fleet = pd.read_parquet(root / "summary" / "fleet_status.parquet")
    assert fleet.to_dict("records")[0]["ok"] == 3
    assert read_provenance(root / "batch_status.parquet")["config"]["job"] == "extract"
    checked_table(BATCH_STATUS_TABLE, pq.read_table(root / "batch_status.parquet"))

    # same content, tool, config: skipped, outputs untouched
    stamp = {rid: (root / rid / MARKER).stat().st_mtime_ns for rid in ok["recording_id"]}
    again = run_batch(entries, _params(root, retries=0))
    assert again.counts == {"ok": 0, "partial": 0, "failed": 2, "skipped": 3}
    assert stamp == {rid: (root / rid / MARKER).stat().st_mtime_ns for rid in stamp}
    status = read_status(root)
    skipped = status[status["status"] == "skipped"]
    assert (skipped["result"] == "ok").all()

    # a new config changes the key: redone and replaced in place, nothing left beside it
    drive = [e for e in entries if e.path.name == "drive_00.mcap"]
    jpg = run_batch(drive, _params(root, config={"frame_format": "png"}, workers=1))
    assert jpg.counts["ok"] == 1, jpg.failures
    rid = next(r for r in stamp if r.startswith("drive_00-"))
    assert len(list((root / rid / "frames").rglob("*.png"))) == 10
    assert sorted(p.name for p in root.iterdir()) == sorted(
        [*stamp, "batch_status.parquet", "summary"]  # failed: no folder; no lock left
    )
    forced = run_batch(drive, _params(root, config={"frame_format": "png"}, force=True))
    assert forced.counts["ok"] == 1


def test_manifest_labels_and_windows_flow_into_tables(
    tmp_path: Path, write_drive: Callable[..., Path]
) -> None:
    rec = write_drive(tmp_path / "d.mcap", seed=5)
    entries = [
        BatchEntry(rec, "highway", "car7", "2024-05-01", "first", 0.0, 0.45),
        BatchEntry(rec, "city", "car7", "2024-05-01", "second", 0.45, None),
    ]
    root = tmp_path / "out"
    report = run_batch(entries, _params(root))
    assert report.counts["ok"] == 2
    status = read_status(root).set_index("sequence")
    assert status.loc["first", "category"] == "highway"
    assert status.loc["first", "frames"] == 5
    assert status.loc["second", "frames"] == 5
    assert status.loc["second", "start_s"] == 0.45
    fleet = pd.read_parquet(root / "summary" / "fleet_status.parquet")
    assert sorted(fleet["category"]) == ["city", "highway"]


def test_stale_tmp_is_cleaned_and_root_locked(tmp_path: Path) -> None:
    root = tmp_path / "out"
    tmp = root / ".tmp"
    dead = tmp / f"rec-0123456789.{socket.gethostname()}.999999999"
    alive = tmp / f"rec-0123456789.{socket.gethostname()}.{os.getpid()}"
    other = tmp / "rec-0123456789.otherhost.12"
    for folder in (dead, alive, other):
        (folder / "frames").mkdir(parents=True)
        (folder / "half.parquet").write_bytes(b"PAR1")
    removed = clean_stale_tmp(root)
    assert sorted(removed) == sorted([dead, other])
    assert alive.is_dir()
    with root_lock(root), pytest.raises(BatchError, match="another slt batch"), root_lock(root):
        pass


def test_lock_file_is_removed_on_exit_and_after_an_error(tmp_path: Path) -> None:
    root = tmp_path / "out"
    with root_lock(root):
        held = (root / ".batch.lock").read_text()
        assert f"pid {os.getpid()} on {socket.gethostname()}" in held
        refused = pytest.raises(BatchError, match=rf"running on .*\(pid {os.getpid()} on ")
        with refused, root_lock(root):
            pass
        assert (root / ".batch.lock").exists()  # the refused batch leaves the holder's file
    assert not (root / ".batch.lock").exists()
    with pytest.raises(RuntimeError), root_lock(root):
        raise RuntimeError("the batch failed")
    assert not (root / ".batch.lock").exists()


def test_lock_of_a_killed_batch_is_taken_over(tmp_path: Path) -> None:
    root = tmp_path / "out"
    code = (
        "import sys, time; from pathlib import Path; "
        "from superlane_tools.commands.batch.root import root_lock\n"
        "with root_lock(Path(sys.argv[1])):\n print('locked', flush=True); time.sleep(60)"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])}
    argv = [sys.executable, "-c", code, str(root)]
    with subprocess.Popen(argv, stdout=subprocess.PIPE, text=True, env=env) as proc:
        try:
            assert proc.stdout is not None
            assert proc.stdout.readline().strip() == "locked"
            with pytest.raises(BatchError, match="another slt batch"), root_lock(root):
                pass
        finally:
            proc.kill()  # SIGKILL: no clean-up runs, the file stays
    assert f"pid {proc.pid}" in (root / ".batch.lock").read_text()
    with root_lock(root):
        assert f"pid {os.getpid()}" in (root / ".batch.lock").read_text()
    assert not (root / ".batch.lock").exists()


def test_unwritable_root(tmp_path: Path, make_drives: Callable[..., list[Path]]) -> None:
    make_drives(1)
    (tmp_path / "file").write_text("x")
    with pytest.raises(BatchError, match="not writable"):
        run_batch(expand_inputs([tmp_path / "recs"]), _params(tmp_path / "file" / "out"))


def test_summary_from_reprocess_tables(tmp_path: Path) -> None:
    """Availability and curvature tables are aggregated from per-run Parquet files."""
    root = tmp_path / "out"
    rows = []
    for k, category in enumerate(["highway", "highway", "rain"]):
        rid = f"d{k}-{k:010d}"
        (root / rid).mkdir(parents=True)
        seqs = pd.DataFrame(
            {
                "method": ["super", "super", "hough", "hough"],
                "category": ["", "", "", ""],
                "n_frames": [10, 10, 10, 10],
                "n_available": [10, 4, 5, 0],
                "available": pd.array([True, False, None, False], dtype="boolean"),
                "method_available": [True, True, True, True],
            }
        )
        write_table(seqs, root / rid / "availability_sequences.parquet", Provenance("test"))
        truth = np.full(20, 1e-3)
        truth[0] = np.nan
        pd.DataFrame(
            {
                "rtk_curvature": truth,
                "super_curvature": truth + 1e-4,
                "mobileye_curvature": np.full(20, np.nan),
            }
        ).to_parquet(root / rid / "curvature.parquet")
        write_run_manifest(root / rid)  # a complete run: the paper-table layout reads it
        rows.append({"recording_id": rid, "category": category, "status": "ok", "result": "ok"})
    table = StatusTable(root, "test", {})
    for row in rows:
        table.update(
            StatusRow(
                recording_id=row["recording_id"],
                recording="/r/x.mcap",
                category=row["category"],
                vehicle="",
                date="",
                sequence="",
                start_s=None,
                end_s=None,
                content_hash="blake3:" + "0" * 64,
                size_bytes=1,
                mtime_ns=1,
                status="ok",
                result="ok",
                error="",
                attempts=1,
                total_s=1.0,
                timings={},
                outputs=3,
                frames=20,
                job="reprocess",
                models={},
                config_sha256="",
                key="k",
                engine="local",
                host="h",
            )
        )
    write_summary(root)
    avail = pd.read_parquet(root / "summary" / "availability_by_category.parquet")
    hw = avail.set_index(["category", "method"]).loc[("highway", "super")]
    assert (hw["n"], hw["N"], hw["k"], hw["K"], hw["recordings"]) == (28, 40, 2, 4, 2)
    rain = avail.set_index(["category", "method"]).loc[("rain", "hough")]
    assert (rain["n"], rain["k"], rain["K"]) == (5, 0, 2)
    curv = pd.read_parquet(root / "summary" / "curvature_by_recording.parquet")
    sup = curv[curv["source"] == "super"]
    assert len(sup) == 3
    assert np.allclose(sup["rmse"], 1e-4)
    assert (sup["n"] == 19).all()
    assert (curv[curv["source"] == "mobileye"]["n"] == 0).all()
    for name, spec in tables_of("summary").items():  # the declared schemas
        checked_table(spec, pq.read_table(SummaryLayout(root / "summary").table(name)))
    md = (root / "summary" / "report.md").read_text()
    assert "## Availability by category" in md
    assert "| highway | super | 2 | 4 | 28 | 40 |" in md
    assert "<table>" in (root / "summary" / "report.html").read_text()
    # Table II layout: the category column holds the recordings' categories, never run ids.
    table_ii = md.split("## Availability, corridor paper Table II layout")[1].split("## ")[0]
    rows = [line for line in table_ii.splitlines() if line.startswith("|")][2:]
    groups = [row.split("|")[1].strip() for row in rows]
    assert groups == ["highway", "rain", "total"]


def test_status_rows_with_sha256_identities_are_not_reused(tmp_path: Path) -> None:
    """A root written before BLAKE3 identities: its SHA-256 rows make the input hashed again."""
    from superlane_tools.commands.batch.manifest import recording_id
    from superlane_tools.commands.batch.plan import identify, job_key
    from superlane_tools.commands.batch.status import STATUS_FILE

    rec = tmp_path / "drive.mcap"
    rec.write_bytes(b"recording bytes")
    stat = rec.stat()
    root = tmp_path / "out"
    root.mkdir()
    old_sha = "a" * 64

    def row(rid: str, content_hash: str) -> StatusRow:
        return StatusRow(
            recording_id=rid, recording=str(rec), category="", vehicle="", date="",
            sequence="", start_s=None, end_s=None, content_hash=content_hash,
            size_bytes=stat.st_size, mtime_ns=stat.st_mtime_ns, status="ok", result="ok",
            error="", attempts=1, total_s=1.0, timings={}, outputs=1, frames=1, job="extract",
            models={}, config_sha256="", key="k", engine="local", host="h",
        )  # fmt: skip

    old = row("drive-aaaaaaaaaa", "").as_record()
    old["sha256"] = old.pop("content_hash")  # the column before BLAKE3 identities
    old["sha256"] = old_sha
    pd.DataFrame([old]).to_parquet(root / STATUS_FILE)
    table = StatusTable(root, "test", {})
    assert table.known_hash(str(rec), stat.st_size, stat.st_mtime_ns) is None
    ident = identify(BatchEntry(rec), table)
    assert isinstance(ident, tuple)
    content_hash = ident[0]
    assert content_hash.startswith("blake3:")
    assert recording_id(BatchEntry(rec), content_hash) == f"drive-{content_hash[7:17]}"
    assert job_key(content_hash, "extract", {}, "c") != job_key(old_sha, "extract", {}, "c")
    # A row of the current algorithm is reused while size and mtime are unchanged.
    table.update(row("drive-x", content_hash), write=False)
    assert table.known_hash(str(rec), stat.st_size, stat.st_mtime_ns) == content_hash


@pytest.mark.parametrize("kind", ["extract", "reprocess"])
def test_preloaded_modules_exist(kind: str) -> None:
    """The fork server ignores a preload module it cannot import: a typo would cost silently."""
    import importlib

    from superlane_tools.commands.batch.kinds import job_kind

    preload = job_kind(kind).preload
    assert preload
    for name in preload:
        importlib.import_module(name)
