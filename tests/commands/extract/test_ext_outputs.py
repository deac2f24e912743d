"""Extract outputs under reruns and failures; background hashing; the MCAP chunk prefetcher."""

from __future__ import annotations

import threading
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
from blake3 import blake3

from superlane_tools.commands.extract import ExtractConfig, extract
from superlane_tools.recording.mcap_source import McapRecording
from superlane_tools.recording.messages import can_frame, compressed_image, navsatfix
from superlane_tools.recording.writers import open_writer
from superlane_tools.reporting import file_sha256, input_identity, read_provenance
from superlane_tools.reporting.provenance import HashCancelledError, PendingIdentities

T0 = 1_700_000_000_000_000_000
MS = 1_000_000
N_FRAMES = 30


def _jpeg(seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)
    return cv2.imencode(".jpg", img)[1].tobytes()


def _write(path: Path, chunk_size: int = 4096) -> list[bytes]:
    """30 frames at 10 Hz, 100 Hz CAN and 10 Hz GNSS in small chunks (many chunks to load)."""
    jpegs = [_jpeg(i) for i in range(N_FRAMES)]
    with open_writer(path, "mcap", chunk_size=chunk_size) as w:
        w.add_topic("/cam", "sensor_msgs/msg/CompressedImage")
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(N_FRAMES):
            t = T0 + i * 100 * MS
            w.write("/cam", t, compressed_image(t, "cam", "jpeg", jpegs[i]))
            w.write("/fix", t + MS, navsatfix(t, "gps", 48.0 + i * 1e-5, 11.0, 500.0, status=2))
            for j in range(10):
                tc = t + j * 10 * MS + 2 * MS
                w.write("/can", tc, can_frame(tc, 256, bytes([i, j]) + bytes(6)))
    return jpegs


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob(".*"))


def test_rerun_replaces_frame_folder_and_hashes_input(tmp_path: Path) -> None:
    rec = tmp_path / "r.mcap"
    jpegs = _write(rec)
    out = tmp_path / "out"
    extract(rec, out, ExtractConfig())
    folder = out / "frames" / "cam"
    assert len(list(folder.iterdir())) == N_FRAMES
    result = extract(rec, out, ExtractConfig(every=3), command="again")
    frames = pd.read_parquet(out / "frames.parquet")
    assert frames["index"].tolist() == list(range(0, N_FRAMES, 3))
    # The folder holds exactly this run's frames: the first run's others are gone.
    assert sorted(p.name for p in folder.iterdir()) == [Path(p).name for p in frames["path"]]
    for row in frames.itertuples():
        assert (out / row.path).read_bytes() == jpegs[row.index]
    assert _hidden(out) == []  # no staging or replaced folders left behind
    assert result.counts["frames"] == N_FRAMES // 3
    for name in ("frames.parquet", "can_raw.parquet", "rtk.parquet"):
        prov = read_provenance(out / name)
        assert prov["inputs"] == [
            {
                "name": "r.mcap",
                "size_bytes": rec.stat().st_size,
                "content_hash": "blake3:" + blake3(rec.read_bytes()).hexdigest(),
            }
        ]
        assert prov["command"] == "again"


def test_failed_extract_leaves_earlier_outputs_and_no_partial_files(tmp_path: Path) -> None:
    rec = tmp_path / "r.mcap"
    _write(rec)
    out = tmp_path / "out"
    extract(rec, out, ExtractConfig(every=2))
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}

    def interrupt(done: int, total: int | None) -> None:
        raise KeyboardInterrupt  # as if Ctrl-C came after the first 256 messages

    with pytest.raises(KeyboardInterrupt):
        extract(rec, out, ExtractConfig(), progress=interrupt)
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert _hidden(out) == []


def test_pending_identities_match_and_cancel(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("x: 1\n")
    (bag / "data.bin").write_bytes(bytes(range(256)) * 9000)
    single = tmp_path / "one.bin"
    single.write_bytes(b"abc")
    pending = PendingIdentities([bag, single])
    assert pending.result() == (input_identity(bag), input_identity(single))
    big = tmp_path / "big.bin"
    big.write_bytes(bytes(4 << 20))
    cancelled = PendingIdentities([big])
    cancelled.cancel()
    with pytest.raises(HashCancelledError):
        cancelled.result()
    with pytest.raises(FileNotFoundError):
        PendingIdentities([tmp_path / "missing.bin"]).result()


def test_input_identity_is_a_named_content_hash(tmp_path: Path) -> None:
    data = bytes(range(256)) * 40000  # several 4 MiB reads
    one = tmp_path / "one.bin"
    one.write_bytes(data)
    ident = input_identity(one)
    assert ident.content_hash == "blake3:" + blake3(data).hexdigest()
    assert (ident.algorithm, ident.hex_digest) == ("blake3", blake3(data).hexdigest())
    old = input_identity(one, "sha256")
    assert old.content_hash == "sha256:" + file_sha256(one)
    assert old != ident  # a SHA-256 identity never equals a BLAKE3 one
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "a.db3").write_bytes(data)
    (bag / "metadata.yaml").write_text("x: 1\n")
    meta = blake3(b"x: 1\n").hexdigest()
    listing = f"a.db3\0{blake3(data).hexdigest()}\nmetadata.yaml\0{meta}\n"
    assert input_identity(bag).content_hash == "blake3:" + blake3(listing.encode()).hexdigest()
    (bag / "metadata.yaml").write_text("x: 2\n")
    assert input_identity(bag).content_hash != "blake3:" + blake3(listing.encode()).hexdigest()


def test_prefetched_chunks_survive_abandoned_passes(tmp_path: Path) -> None:
    rec = tmp_path / "r.mcap"
    _write(rec, chunk_size=2048)
    threads_before = threading.active_count()
    with McapRecording(rec) as source:
        for _ in range(3):  # stop early: the generator's prefetch thread must shut down
            partial = source.messages()
            first = [next(partial) for _ in range(5)]
            partial.close()
            assert [m.log_time_ns for m in first] == sorted(m.log_time_ns for m in first)
        assert threading.active_count() == threads_before
        times = [m.log_time_ns for m in source.raw_messages()]
        cams = list(source.messages(topics=["/cam"], start_ns=T0 + 1, stop_ns=None))
    assert len(times) == N_FRAMES * 12
    assert times == sorted(times)
    assert [m.stamp_ns for m in cams] == [T0 + i * 100 * MS for i in range(1, N_FRAMES)]
    assert threading.active_count() == threads_before
