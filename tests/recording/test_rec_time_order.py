"""MCAP messages come out in log-time order whatever order the file holds them in."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from superlane_tools.recording import mcap_source, open_recording

CHUNK_BYTES = 4096
"""Chunk size of the test files; the last message of each group is padded past it, which
closes the chunk right after it (the writer closes a chunk once it exceeds its size)."""


def _write_chunked(path: Path, chunks: list[list[int]]) -> None:
    """One JSON channel; chunk k holds exactly the log times ``chunks[k]``, in the given order."""
    with path.open("wb") as handle:
        writer = Writer(handle, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        writer.start()
        schema = writer.register_schema("Tick", "jsonschema", b'{"type": "object"}')
        channel = writer.register_channel("/tick", "json", schema)
        for times in chunks:
            for k, t in enumerate(times):
                pad = "x" * (CHUNK_BYTES + 1) if k == len(times) - 1 else ""
                writer.add_message(channel, t, json.dumps({"t": t, "pad": pad}).encode(), t)
        writer.finish()


@pytest.mark.parametrize(
    "chunks",
    [
        [[0, 10, 20], [30, 40], [50]],  # one after the other
        [[0, 10, 20, 30], [5, 15, 25], [35, 40]],  # overlapping chunks
        [[20, 0, 10], [30, 25]],  # out of order inside a chunk
        [[10, 10, 20], [20, 20, 30]],  # equal times across the chunk boundary
        [[40, 50], [0, 5], [45]],  # a later chunk holds earlier messages
    ],
)
@pytest.mark.parametrize("loaders", [1, 2, 3])
def test_messages_in_log_time_order(
    tmp_path: Path, chunks: list[list[int]], loaders: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "ticks.mcap"
    _write_chunked(path, chunks)
    monkeypatch.setattr(mcap_source, "LOADER_THREADS", loaders)  # 1 to 3: the same order
    with open_recording(path) as rec:
        got = [(m.log_time_ns, m.data.t) for m in rec.messages()]
        windowed = [m.log_time_ns for m in rec.messages(start_ns=10, stop_ns=40)]
    expected = sorted(t for times in chunks for t in times)
    assert [t for t, _ in got] == expected
    assert all(t == payload for t, payload in got)
    assert windowed == [t for t in expected if 10 <= t < 40]
    with path.open("rb") as handle:  # the file really holds the chunks the case describes
        summary = make_reader(handle).get_summary()
    assert summary is not None
    assert [(c.message_start_time, c.message_end_time) for c in summary.chunk_indexes] == [
        (min(times), max(times)) for times in chunks
    ]
