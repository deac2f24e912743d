"""Benchmark ``slt info`` on a 1 GB MCAP with a summary section (summary-only answer).

Run: ``python benchmarks/bench_info.py [--gib 0.1 1.0] [--keep]``.

For each size, writes a ``--gib`` GiB MCAP into the system temp folder with the project's
writer (1 MiB JPEG-like ``CompressedImage`` payloads at 10 Hz plus 100 Hz CAN frames, chunk
compression none), then times, like for like: (a) the library path (``mcap_file_info`` +
``summary_from_mcap``) against the ``mcap`` library's own ``get_summary()``, after a warm-up,
interleaved and alternating which goes first, median of 6; (b) the whole ``slt info --json``
command in a fresh process (Python start-up and imports included) against a fresh process that
only reads the summary with ``mcap``, median of 3, with the children's CPU time (user +
system): on a shared, loaded machine the wall time also holds waiting for a core. Two sizes
show whether the time depends on the file size. Writes ``benchmarks/results/info.json``; the
files are removed unless ``--keep``.
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
from _machine import uptime

from superlane_tools.recording import messages as m
from superlane_tools.recording import open_writer
from superlane_tools.recording.inspect import mcap_file_info, summary_from_mcap

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


_MCAP_SUMMARY = (
    "import sys\n"
    "from mcap.reader import make_reader\n"
    "with open(sys.argv[1], 'rb') as f:\n"
    "    s = make_reader(f).get_summary()\n"
    "print(sum(s.statistics.channel_message_counts.values()))\n"
)
"""The ``mcap`` library's own summary read as a command: a fresh Python process, no slt."""


def _mcap_summary(path: Path) -> int:
    """The ``mcap`` library's own summary read (the like-for-like library baseline)."""
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    assert summary.statistics is not None
    return sum(summary.statistics.channel_message_counts.values())


def _child(argv: list[str]) -> tuple[float, float, str]:
    """Run a fresh process; return wall seconds, its CPU seconds and stdout."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    out = subprocess.run(argv, capture_output=True, check=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, out.stdout


def _measure(path: Path) -> dict[str, object]:
    """Interleave the four timings on one file: library vs library, command vs command."""
    med = statistics.median
    lib, base, cmd, cpu, bcmd, bcpu = [], [], [], [], [], []

    def ours() -> int:
        info = mcap_file_info(path)
        assert info is not None
        return summary_from_mcap(path, info).message_count

    assert ours() == _mcap_summary(path)  # warm-up: both read the same pages from the cache
    for k in range(6):  # alternate which goes first (the page cache may drop pages between)
        for fn, times in ((ours, lib), (lambda: _mcap_summary(path), base))[:: 1 - 2 * (k % 2)]:
            t = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t)
    summary = summary_from_mcap(path, mcap_file_info(path))  # type: ignore[arg-type]
    for _ in range(3):
        wall, c, stdout = _child([sys.executable, "-c", _MAIN, "info", str(path), "--json"])
        cmd.append(wall)
        cpu.append(c)
        doc = json.loads(stdout)
        wall, c, _ = _child([sys.executable, "-c", _MCAP_SUMMARY, str(path)])
        bcmd.append(wall)
        bcpu.append(c)
    return {
        "file_bytes": path.stat().st_size,
        "messages": summary.message_count,
        "read_from": doc["read_from"],
        "library_median_s": med(lib),
        "mcap_library_summary_median_s": med(base),
        "library_over_mcap_library": med(lib) / med(base),
        "command_median_s": med(cmd),
        "command_s": cmd,
        "command_cpu_median_s": med(cpu),
        "mcap_summary_command_median_s": med(bcmd),
        "mcap_summary_command_cpu_median_s": med(bcpu),
        "command_over_mcap_command": med(cmd) / med(bcmd),
    }


def main() -> None:
    """Run the benchmark and write its JSON result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gib", type=float, nargs="+", default=[0.1, 1.0])
    parser.add_argument("--keep", action="store_true")
    args = parser.parse_args()
    load = [uptime()]
    sizes = {}
    for gib in args.gib:
        path = Path(tempfile.gettempdir()) / f"slt_bench_info_{gib:g}gib.mcap"
        t0 = time.perf_counter()
        if not path.exists():
            _write(path, gib)
        sizes[f"{gib:g}_gib"] = {"write_s": time.perf_counter() - t0, **_measure(path)}
        if not args.keep:
            path.unlink()
    load.append(uptime())
    largest = sizes[f"{max(args.gib):g}_gib"]
    result = {
        "command": "python benchmarks/bench_info.py " + " ".join(sys.argv[1:]),
        "data": "simulated MCAP (1 MiB random CompressedImage payloads at 10 Hz, 100 Hz CAN)",
        "target": "slt info <= 2x mcap's own summary read on a 1 GB file, time independent of size",
        "library_over_mcap_library": largest["library_over_mcap_library"],
        "command_over_mcap_command": largest["command_over_mcap_command"],
        "sizes": sizes,
        "uptime": load,
        "machine": platform.platform(),
    }
    (Path(__file__).parent / "results" / "info.json").write_text(
        json.dumps(result, indent=2) + "\n", encoding="utf-8"
    )
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
