"""Benchmark `slt extract` against plain MCAP iteration+decoding, and its memory growth.

Run: ``python benchmarks/bench_extract.py``. Generates a 60 s recording (15 Hz 1280x720 JPEG
frames, 100 Hz CAN, 20 Hz GNSS) with the project's writers, times (median of 3) decoding all
messages with the mcap library alone versus the full extract, then measures peak RSS of the
extract on the 60 s recording and on a 10x longer one, each in a fresh subprocess. Writes
``benchmarks/results/extract.json``.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results" / "extract.json"
REALDATA = Path(
    os.environ.get("SLT_REALDATA", Path(__file__).resolve().parents[2] / "shared" / "data")
)
FRAMES = REALDATA / "tusimple" / "frames"
T0 = 1_700_000_000_000_000_000
DBC = """VERSION ""

NS_ :

BS_:

BU_: ECU

BO_ 256 Motion: 8 ECU
 SG_ Speed : 0|16@1+ (0.01,0) [0|655.35] "m/s" ECU
 SG_ Yaw : 16|12@1- (0.1,-5) [-210|200] "deg/s" ECU
"""


def jpeg_pool(quality: int = 90) -> list[bytes]:
    """Realistic 1280x720 camera JPEGs: the real TuSimple frames encoded at ``quality``.

    About 160 KB per frame (a real highway camera's JPEG size); needs the shared data folder
    (``$SLT_REALDATA`` or ``../shared/data``).
    """
    import cv2

    files = sorted(FRAMES.glob("*.png")) + sorted((FRAMES / "unlabeled").glob("*.jpg"))
    images = [cv2.imread(str(p), cv2.IMREAD_COLOR) for p in files]
    images = [cv2.resize(i, (1280, 720)) for i in images if i is not None]
    if not images:
        raise SystemExit(f"no TuSimple frames under {FRAMES}: set SLT_REALDATA")
    params = [cv2.IMWRITE_JPEG_QUALITY, quality]
    return [cv2.imencode(".jpg", img, params)[1].tobytes() for img in images]


def make_recording(path: Path, seconds: int, pool: list[bytes]) -> None:
    """Write an MCAP with 15 Hz frames, 100 Hz CAN and 20 Hz GNSS for ``seconds``."""
    from superlane_tools.recording.messages import can_frame, compressed_image, navsatfix
    from superlane_tools.recording.writers import open_writer

    events: list[tuple[int, str, int]] = []
    events += [(T0 + i * 1_000_000_000 // 15, "/cam", i) for i in range(seconds * 15)]
    events += [(T0 + i * 10_000_000, "/can", i) for i in range(seconds * 100)]
    events += [(T0 + i * 50_000_000, "/fix", i) for i in range(seconds * 20)]
    events.sort()
    with open_writer(path, "mcap") as writer:
        writer.add_topic("/cam", "sensor_msgs/msg/CompressedImage")
        writer.add_topic("/can", "can_msgs/msg/Frame")
        writer.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for t, topic, i in events:
            if topic == "/cam":
                msg = compressed_image(t, "cam", "jpeg", pool[i % len(pool)])
            elif topic == "/can":
                msg = can_frame(t, 256, int(1000 + i % 5000).to_bytes(2, "little") + bytes(6))
            else:
                msg = navsatfix(t, "gps", 48.0 + i * 2e-6, 11.0, 500.0, status=2)
            writer.write(topic, t, msg)


def baseline(path: Path) -> int:
    """Iterate and decode every message with the mcap library alone."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    count = 0
    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _ in reader.iter_decoded_messages():
            count += 1
    return count


def run_extract(path: Path, dbc: Path, out: Path, frames: str = "jpg") -> dict[str, int]:
    """The full extract (frames as JPEG files, CAN raw + decoded, RTK table)."""
    from superlane_tools.pipeline import ExtractConfig, extract

    config = ExtractConfig(dbc_paths=(dbc,), frame_format=frames)
    result = extract(path, out, config, command="bench")
    return dict(result.counts)


def run_extract_index_only(path: Path, dbc: Path, out: Path) -> dict[str, int]:
    """The extract without writing image files (``--frames none``)."""
    return run_extract(path, dbc, out, frames="none")


def write_only(pool: list[bytes], count: int, out: Path) -> int:
    """Just write ``count`` JPEG files of the pool: the disk's share of the full extract."""
    out.mkdir(parents=True)
    for i in range(count):
        (out / f"{i:06d}.jpg").write_bytes(pool[i % len(pool)])
    return count


def median_time(func, *args, out: Path | None = None) -> tuple[float, object]:  # type: ignore[no-untyped-def]
    """Median wall time of 3 runs; ``out`` (an output folder) is removed between runs."""
    times, value = [], None
    for _ in range(3):
        start = time.perf_counter()
        value = func(*args) if out is None else func(*args, out)
        times.append(time.perf_counter() - start)
        if out is not None:
            shutil.rmtree(out)
    return statistics.median(times), value


def peak_rss_mib(path: Path, out: Path, dbc: Path) -> float:
    """Peak resident memory of one extract in a fresh interpreter, MiB."""
    code = (
        "import resource, sys\n"
        f"sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "from bench_extract import run_extract\n"
        "from pathlib import Path\n"
        f"run_extract(Path({str(path)!r}), Path({str(dbc)!r}), Path({str(out)!r}))\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(done.stdout.strip().splitlines()[-1]) / 1024.0


def main() -> None:
    work = Path(tempfile.mkdtemp(prefix="slt-bench-extract-"))
    try:
        dbc = work / "bench.dbc"
        dbc.write_text(DBC)
        pool = jpeg_pool()
        short, long = work / "60s.mcap", work / "600s.mcap"
        make_recording(short, 60, pool)
        t_base, n_msgs = median_time(baseline, short)
        t_extract, counts = median_time(run_extract, short, dbc, out=work / "out")
        t_index, _ = median_time(run_extract_index_only, short, dbc, out=work / "out")
        t_write, _ = median_time(write_only, pool, 900, out=work / "out")
        rss_short = peak_rss_mib(short, work / "out-s", dbc)
        shutil.rmtree(work / "out-s")
        make_recording(long, 600, pool)
        rss_long = peak_rss_mib(long, work / "out-l", dbc)
        results = {
            "recording_s": 60,
            "messages": n_msgs,
            "recording_mib": round(short.stat().st_size / 2**20, 1),
            "baseline_mcap_decode_s": round(t_base, 3),
            "extract_s": round(t_extract, 3),
            "extract_over_baseline": round(t_extract / t_base, 2),
            "write_900_jpeg_files_only_s": round(t_write, 3),
            "extract_over_baseline_plus_writes": round(t_extract / (t_base + t_write), 2),
            "extract_frames_none_s": round(t_index, 3),
            "extract_frames_none_over_baseline": round(t_index / t_base, 2),
            "target_ratio": 1.5,
            "counts": counts,
            "peak_rss_60s_mib": round(rss_short, 1),
            "peak_rss_600s_mib": round(rss_long, 1),
            "rss_ratio_600s_over_60s": round(rss_long / rss_short, 3),
            "target_rss_ratio": 1.2,
        }
    finally:
        shutil.rmtree(work, ignore_errors=True)
    width = max(len(k) for k in results)
    for key, value in results.items():
        print(f"{key:<{width}}  {value}")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
