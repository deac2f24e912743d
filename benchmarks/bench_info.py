"""Benchmark ``slt info`` on a 1 GB MCAP with a summary section (summary-only answer).

Run: ``python benchmarks/bench_info.py [--gib 1.0] [--keep]``.

Writes a ``--gib`` GiB MCAP into the system temp folder with the project's writer (1 MiB JPEG-like
``CompressedImage`` payloads at 10 Hz plus 100 Hz CAN frames, chunk compression none), then times
(a) the library path (``mcap_file_info`` + ``summary_from_mcap``), median of 5, and (b) the whole
``slt info --json`` command in a fresh process (Python start-up and imports included), median
of 3, with the child's CPU time (user + system): on a shared, loaded machine the wall time
also holds waiting for a core. Writes ``benchmarks/results/info.json``; the file is removed
unless ``--keep``.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from superlane_tools.recording import messages as m
from superlane_tools.recording.inspect import mcap_file_info, summary_from_mcap
from superlane_tools.recording.writers import open_writer

T0 = 1_700_000_000_000_000_000
_MAIN = "from superlane_tools.cli.app import main; main()"


def _write(path: Path, gib: float) -> int:
    payload = np.random.default_rng(0).integers(0, 255, 1 << 20, dtype=np.uint8).tobytes()
    frames = round(gib * 1024)
    with open_writer(path, "mcap", compression="none", chunk_size=4 << 20) as w:
        w.add_topic("/camera/image/compressed", "sensor_msgs/msg/CompressedImage")
        w.add_topic("/can", "can_msgs/msg/Frame")
        for i in range(frames):
            t = T0 + i * 100_000_000
            w.write("/camera/image/compressed", t, m.compressed_image(t, "cam", "jpeg", payload))
            for j in range(10):
                tc = t + j * 10_000_000
                w.write("/can", tc, m.can_frame(tc, 0x100 + j, bytes(8)))
    return frames * 11


def main() -> None:
    """Run the benchmark and write its JSON result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gib", type=float, default=1.0)
    parser.add_argument("--keep", action="store_true")
    args = parser.parse_args()
    path = Path(tempfile.gettempdir()) / f"slt_bench_info_{args.gib:g}gib.mcap"
    t0 = time.perf_counter()
    if not path.exists():
        _write(path, args.gib)
    write_s = time.perf_counter() - t0
    lib = []
    for _ in range(5):
        t = time.perf_counter()
        info = mcap_file_info(path)
        assert info is not None
        summary = summary_from_mcap(path, info)
        lib.append(time.perf_counter() - t)
    cmd, cpu = [], []
    for _ in range(3):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        out = subprocess.run(
            [sys.executable, "-c", _MAIN, "info", str(path), "--json"],
            capture_output=True,
            check=True,
            text=True,
        )
        cmd.append(time.perf_counter() - t)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    doc = json.loads(out.stdout)
    result = {
        "file_bytes": path.stat().st_size,
        "messages": summary.message_count,
        "read_from": doc["read_from"],
        "write_s": write_s,
        "library_median_s": statistics.median(lib),
        "command_median_s": statistics.median(cmd),
        "command_s": cmd,
        "command_cpu_median_s": statistics.median(cpu),
        "machine": platform.platform(),
    }
    (Path(__file__).parent / "results" / "info.json").write_text(
        json.dumps(result, indent=2) + "\n", encoding="utf-8"
    )
    print(json.dumps(result, indent=2))
    if not args.keep:
        path.unlink()


if __name__ == "__main__":
    main()
