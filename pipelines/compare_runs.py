"""Compare two ``slt reprocess`` output folders table by table, cell by cell.

Every Parquet table must have the same columns, types and rows; float cells must be equal
(NaN equals NaN) or, with ``--rtol``, close. Provenance metadata (command line, time, version)
is ignored, and so are measured times (``*_ms`` columns: the stage times of ``frames.parquet``
and ``fit_time_ms`` of ``lanes.parquet``; wall and CPU time differ from run to run by nature).
``annotations.mcap`` is compared message by message (topic, log time, and the payload bytes, or
the decoded message where the bytes differ: protobuf serialises a ``Struct``'s map fields in no
fixed order), and ``report.md`` line by line (the self-check's measured wall and CPU time and
the report's date masked).

Usage:
    python pipelines/compare_runs.py RUN_A RUN_B [--rtol 0]

Exit codes: 0 identical, 1 differences (each printed), 2 bad command line.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from superlane_tools.reporting.layout import ANNOTATIONS_FILE, REPORT_FILE, RunLayout

TIMING_COLUMN = re.compile(r"_ms$")
"""Measured-time columns (stage times, fit time): never reproducible."""
REPORT_TIME = re.compile(r"self-check on (\d+) frames \(\d+(?:\.\d+)? s\)")
"""A measured time in ``report.md``: the segmentation self-check's wall time."""
REPORT_CHECK_CPU = re.compile(r"self-check cost: \d+(?:\.\d+)? s CPU")
"""The self-check's measured CPU time in ``report.md``."""
REPORT_DATE = re.compile(r"^- date: .* UTC$")
"""The report's date line (when it was written): never reproducible."""
REPORT_TIMING = re.compile(r"^- wall: .*$")
"""The report's Timing section (measured times): never reproducible."""


def _masked(line: str) -> str:
    line = REPORT_TIME.sub(r"self-check on \1 frames (measured s)", line)
    line = REPORT_CHECK_CPU.sub("self-check cost: (measured) s CPU", line)
    line = REPORT_TIMING.sub("- (measured times masked)", line)
    return REPORT_DATE.sub("- date: (masked)", line)


def _columns(table: pa.Table, name: str) -> list[str]:
    del name
    return [c for c in table.column_names if not TIMING_COLUMN.search(c)]


def _cells_differ(a: pa.ChunkedArray, b: pa.ChunkedArray, rtol: float) -> list[int]:
    """Return the row indices where two columns differ (NaN == NaN, None == None)."""
    if pa.types.is_floating(a.type) and pa.types.is_floating(b.type):
        x = a.to_numpy(zero_copy_only=False).astype(np.float64)
        y = b.to_numpy(zero_copy_only=False).astype(np.float64)
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        if rtol > 0:
            same |= np.isclose(x, y, rtol=rtol, atol=0.0)
        return [int(i) for i in np.flatnonzero(~same)]
    xs, ys = a.to_pylist(), b.to_pylist()
    return [i for i, (x, y) in enumerate(zip(xs, ys, strict=True)) if not _equal(x, y)]


def _equal(x: object, y: object) -> bool:
    if isinstance(x, float) and isinstance(y, float):
        return x == y or (np.isnan(x) and np.isnan(y))
    if isinstance(x, list) and isinstance(y, list):
        return len(x) == len(y) and all(_equal(p, q) for p, q in zip(x, y, strict=True))
    if isinstance(x, dict) and isinstance(y, dict):
        return x.keys() == y.keys() and all(_equal(x[k], y[k]) for k in x)
    return x == y


def compare_table(path_a: Path, path_b: Path, rtol: float = 0.0) -> list[str]:
    """Return the differences between two Parquet tables (empty when identical)."""
    name = path_a.name
    a, b = pq.read_table(path_a), pq.read_table(path_b)
    cols_a, cols_b = _columns(a, name), _columns(b, name)
    if cols_a != cols_b:
        return [f"{name}: columns differ: {cols_a} vs {cols_b}"]
    if a.num_rows != b.num_rows:
        return [f"{name}: {a.num_rows} vs {b.num_rows} rows"]
    out = []
    for col in cols_a:
        if a.schema.field(col).type != b.schema.field(col).type:
            out.append(
                f"{name}.{col}: type {a.schema.field(col).type} vs {b.schema.field(col).type}"
            )
            continue
        rows = _cells_differ(a[col], b[col], rtol)
        if rows:
            i = rows[0]
            out.append(
                f"{name}.{col}: {len(rows)} cells differ, first row {i}: "
                f"{a[col][i].as_py()!r} vs {b[col][i].as_py()!r}"
            )
    return out


def compare_mcap(path_a: Path, path_b: Path) -> list[str]:
    """Return the differences between two MCAP files' messages (topic, log time, content)."""
    import json

    from google.protobuf.json_format import MessageToDict
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    protobuf = DecoderFactory()

    def content(encoding: str, schema: Any, data: bytes) -> object:
        if encoding == "json":
            return json.loads(data)
        decoder = protobuf.decoder_for(encoding, schema)
        return MessageToDict(decoder(data)) if decoder is not None else data

    def messages(path: Path) -> list[tuple[str, int, bytes, str, Any]]:
        with path.open("rb") as handle:
            reader = make_reader(handle)
            return [
                (
                    channel.topic,
                    message.log_time,
                    bytes(message.data),
                    channel.message_encoding,
                    schema,
                )
                for schema, channel, message in reader.iter_messages(log_time_order=True)
            ]

    ma, mb = messages(path_a), messages(path_b)
    if len(ma) != len(mb):
        return [f"{path_a.name}: {len(ma)} vs {len(mb)} messages"]
    bad = [
        i
        for i, (x, y) in enumerate(zip(ma, mb, strict=True))
        if x[:2] != y[:2]
        or (x[2] != y[2] and not _equal(content(x[3], x[4], x[2]), content(y[3], y[4], y[2])))
    ]
    if bad:
        return [f"{path_a.name}: {len(bad)} of {len(ma)} messages differ, first {bad[0]}"]
    return []


def compare_runs(run_a: Path, run_b: Path, rtol: float = 0.0) -> tuple[list[str], list[str]]:
    """Return ``(files compared, differences)`` of two reprocess output folders."""
    names_a = {p.name for p in run_a.glob("*.parquet")}
    names_b = {p.name for p in run_b.glob("*.parquet")}
    diffs = [f"only in {run_a}: {n}" for n in sorted(names_a - names_b)]
    diffs += [f"only in {run_b}: {n}" for n in sorted(names_b - names_a)]
    compared = sorted(names_a & names_b)
    for name in compared:
        diffs += compare_table(run_a / name, run_b / name, rtol)
    a, b = RunLayout(run_a), RunLayout(run_b)
    if a.annotations.is_file() and b.annotations.is_file():
        compared.append(ANNOTATIONS_FILE)
        diffs += compare_mcap(a.annotations, b.annotations)
    if a.report.is_file() and b.report.is_file():
        compared.append(REPORT_FILE)
        la, lb = (
            [_masked(line) for line in lines]
            for lines in (
                a.report.read_text(encoding="utf-8").splitlines(),
                b.report.read_text(encoding="utf-8").splitlines(),
            )
        )
        if la != lb:
            first = next(
                (i for i, (x, y) in enumerate(zip(la, lb, strict=False)) if x != y),
                min(len(la), len(lb)),
            )
            diffs.append(f"{REPORT_FILE} differs from line {first + 1}")
    return compared, diffs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_a", type=Path)
    parser.add_argument("run_b", type=Path)
    parser.add_argument("--rtol", type=float, default=0.0, help="relative tolerance for floats")
    args = parser.parse_args(argv)
    for run in (args.run_a, args.run_b):
        if not run.is_dir():
            parser.error(f"not a folder: {run}")
    compared, diffs = compare_runs(args.run_a, args.run_b, args.rtol)
    for line in diffs:
        print(line)
    print(f"compared {len(compared)} files: {', '.join(compared)}")
    print("IDENTICAL" if not diffs else f"{len(diffs)} DIFFERENCES")
    return 0 if not diffs else 1


if __name__ == "__main__":
    sys.exit(main())
