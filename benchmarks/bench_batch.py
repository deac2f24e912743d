"""Benchmark `slt batch`: 1 vs 2 local workers, Ray vs local, corrupt inputs, kill and resume.

Run: ``python benchmarks/bench_batch.py [--recordings 8] [--frames 20] [--repeats 3]
[--compression zstd|lz4|none] [--ram] [--synthetic] [--skip-kill]``.

Job: ``extract`` with ``frame_format: png`` on 1280x720 JPEG recordings written with the
project's writers from real camera frames (the TuSimple frames of ``$SLT_REALDATA``, as
``bench_extract.py``; ``--synthetic``: the earlier gradient-plus-noise frames, which PNG cannot
compress, so each PNG is 2.7 MB instead of about 0.8 MB and the disk dominates): every frame is
JPEG-decoded and PNG-encoded in the job's thread (the frame writer's threads only write files),
a CPU-bound, single-threaded per-frame load like reprocess's decode and image stages.
Throughput is recordings per second of wall time, median of ``--repeats`` interleaved runs,
each into a fresh output root, pools started inside the timed region; the Ray instance is
started once (``ray.init(num_cpus=2)``) and its start-up is reported apart, as a running
cluster is what ``--ray-address auto`` joins. Both engines keep warm processes between the
batches of one driver (the local engine its fork server, which has imported the package; Ray
its worker processes, which have loaded the job kind), so only the first repeat of each pays
for imports and model loading; ``wall_s`` lists every repeat. ``--compression`` sets the
recordings' MCAP chunk compression (default zstd). With ``--synthetic`` each batch writes about
330 MB of PNG files per recording (2.6 GB for 8); ``--ram`` puts the output roots in
``/dev/shm`` (each removed after its batch), which takes this VM's disk out of the comparison
and leaves the engines' own scaling. Other than the defaults, results go to
``batch_<compression>[_ram][_synthetic].json``. Then a 20-recording batch with 2 corrupt
recordings runs in a subprocess that is SIGKILLed halfway and started again. Writes
``benchmarks/results/batch.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _machine import uptime

RESULTS = Path(__file__).resolve().parent / "results" / "batch.json"
T0 = 1_700_000_000_000_000_000
MS = 1_000_000
SLT = (
    "from superlane_tools.cli.app import app\n"
    "from superlane_tools.cli import batch\n"
    "batch.register(app)\n"
    "app()\n"
)


def real_jpeg_pool() -> list[bytes]:
    """Real 1280x720 camera JPEGs (TuSimple frames, as in bench_extract): real PNG sizes."""
    from bench_extract import jpeg_pool as tusimple_pool  # the sibling script

    return tusimple_pool()


def jpeg_pool(width: int, height: int, count: int = 8) -> list[bytes]:
    """Synthetic frames: gradients plus pixel noise, which PNG cannot compress (2.7 MB each)."""
    import cv2

    rng = np.random.default_rng(0)
    ys, xs = np.mgrid[0:height, 0:width]
    pool = []
    for k in range(count):
        base = np.stack([(xs + 8 * k) % 256, (ys // 3) % 256, (xs + ys) % 256], axis=-1)
        img = np.clip(base + rng.normal(0, 12, base.shape), 0, 255).astype(np.uint8)
        pool.append(cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 85])[1].tobytes())
    return pool


def make_recording(
    path: Path, seed: int, frames: int, pool: list[bytes], compression: str = "zstd"
) -> None:
    from superlane_tools.recording import open_writer
    from superlane_tools.recording.messages import can_frame, compressed_image, navsatfix

    with open_writer(path, "mcap", compression=compression) as w:  # type: ignore[arg-type]
        w.add_topic("/cam/compressed", "sensor_msgs/msg/CompressedImage")
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(frames):
            t = T0 + seed * 10**12 + i * 66 * MS
            jpeg = pool[(i + seed) % len(pool)]
            w.write("/cam/compressed", t, compressed_image(t, "cam", "jpeg", jpeg))
            w.write("/can", t, can_frame(t, 256, bytes([seed % 256, i % 256])))
            w.write("/fix", t, navsatfix(t, "gps", 48 + i * 1e-5, 11.0, 500.0, status=2))


CONFIGURATIONS = (("local_1", "local", 1), ("local_2", "local", 2), ("ray_2", "ray", 2))
"""Name, engine and workers of the batches each repeat runs, in this order."""


def timed_batch(
    recs: Path, root: Path, engine: str, workers: int, remove: bool = False
) -> tuple[float, float]:
    """Run one batch; return its wall seconds and the sum of its jobs' own seconds.

    The jobs' seconds (``total_s`` of the status table, each measured in its worker) show what
    running two at once costs each job: on a machine whose cores slow each other down, the sum
    grows with the workers and bounds the speedup at ``workers x alone / together``.
    """
    import pyarrow.parquet as pq

    from superlane_tools.commands.batch import BatchParams, expand_inputs, run_batch

    params = BatchParams(
        root,
        "extract",
        engine=engine,
        workers=workers,
        config={"frame_format": "png"},
        summary=False,
    )
    entries = expand_inputs([recs])
    t0 = time.perf_counter()
    report = run_batch(entries, params)
    wall = time.perf_counter() - t0
    assert report.counts["ok"] == len(entries), report.failures
    job_s = float(
        sum(pq.read_table(report.status_path, columns=["total_s"])["total_s"].to_pylist())
    )
    if remove:
        shutil.rmtree(root)
    return wall, job_s


def throughput(
    tmp: Path,
    recordings: int,
    frames: int,
    repeats: int,
    compression: str,
    out: Path | None,
    synthetic: bool = False,
) -> dict[str, object]:
    recs = tmp / "recs"
    recs.mkdir()
    pool = jpeg_pool(1280, 720) if synthetic else real_jpeg_pool()
    for k in range(recordings):
        make_recording(recs / f"drive_{k:02d}.mcap", k, frames, pool, compression)
    contention = core_contention(pool[0])
    runs: dict[str, list[float]] = {"local_1": [], "local_2": [], "ray_2": []}
    job_seconds: dict[str, list[float]] = {key: [] for key in runs}
    import ray

    t0 = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    ray_start = time.perf_counter() - t0
    load_before = os.getloadavg()
    try:
        # interleaved, so that the three configurations see the same background load
        for r in range(repeats):
            base, remove = (out, True) if out is not None else (tmp, False)
            for key, engine, workers in CONFIGURATIONS:
                wall, job_s = timed_batch(recs, base / f"{key}_{r}", engine, workers, remove)
                runs[key].append(wall)
                job_seconds[key].append(job_s)
            print(
                f"repeat {r}: local 1 worker {runs['local_1'][-1]:.2f} s, "
                f"2 workers {runs['local_2'][-1]:.2f} s, ray 2 {runs['ray_2'][-1]:.2f} s"
            )
    finally:
        ray.shutdown()
    load_after = os.getloadavg()
    med = {k: statistics.median(v) for k, v in runs.items()}
    rate = {k: recordings / v for k, v in med.items()}
    return {
        "recordings": recordings,
        "frames_per_recording": frames,
        "frame_size": "1280x720",
        "frames_from": "synthetic (gradients + noise, 8 JPEGs)"
        if synthetic
        else f"real TuSimple frames ({len(pool)} JPEGs, quality 90)",
        "mcap_chunk_compression": compression,
        "output_roots": "RAM (/dev/shm)" if out is not None else "disk (temporary folder)",
        "job": "extract, frame_format png (JPEG decode + PNG encode per frame)",
        "wall_s": runs,
        "median_wall_s": med,
        "job_seconds_sum": job_seconds,
        "median_job_seconds_sum": {k: statistics.median(v) for k, v in job_seconds.items()},
        "core_contention": contention,
        "speedup_bound_2_workers": 2
        * statistics.median(job_seconds["local_1"])
        / statistics.median(job_seconds["local_2"]),
        "recordings_per_s": rate,
        "speedup_2_vs_1_local": rate["local_2"] / rate["local_1"],
        "ray_vs_local_2": rate["ray_2"] / rate["local_2"],
        "ray_init_s": ray_start,
        "load_average_before_after": [load_before, load_after],
        "cpus": os.cpu_count(),
    }


def _encode_loop(jpeg: bytes, seconds: float) -> float:
    """PNG-encode one decoded frame for about ``seconds`` on one thread; return ms per encode."""
    import cv2

    cv2.setNumThreads(1)  # a fresh (spawned) process: its OpenCV pool never ran
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    count, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        cv2.imencode(".png", image)
        count += 1
    return 1e3 * (time.perf_counter() - t0) / count


def core_contention(jpeg: bytes, seconds: float = 5.0) -> dict[str, object]:
    """How much slower the job's core loop runs when two processes run it at once.

    The same single-threaded PNG encode, alone, then in two processes together (no I/O, no
    shared state): on ideal cores both run as fast as one alone. Their slowdown bounds what
    two workers can gain on this machine: ``2 x alone / together``.
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(2, mp_context=context) as pool:
        list(pool.map(_encode_loop, [jpeg, jpeg], [0.5, 0.5]))  # both workers started
        alone = pool.submit(_encode_loop, jpeg, seconds).result()
        pair = [pool.submit(_encode_loop, jpeg, seconds) for _ in range(2)]
        together = statistics.mean(f.result() for f in pair)
    return {
        "png_encode_ms_alone": round(alone, 2),
        "png_encode_ms_two_at_once": round(together, 2),
        "speedup_bound_2_processes": round(2 * alone / together, 3),
    }


def kill_and_resume(tmp: Path) -> dict[str, object]:
    from superlane_tools.commands.batch import MARKER, read_status
    from superlane_tools.reporting.layout import BATCH_STATUS_TABLE

    recs = tmp / "kill_recs"
    recs.mkdir()
    pool = jpeg_pool(320, 180)
    for k in range(18):
        make_recording(recs / f"drive_{k:02d}.mcap", k, 20, pool)
    (recs / "corrupt_garbage.mcap").write_bytes(b"not a recording\n" * 64)
    (recs / "corrupt_truncated.mcap").write_bytes(b"\x89MCAP0\r\n\x01\x02")
    root = tmp / "kill_out"

    def cmd_for(out: Path) -> list[str]:
        return [
            sys.executable,
            "-c",
            SLT,
            "batch",
            str(recs),
            "--out",
            str(out),
            "--job",
            "extract",
            "--workers",
            "2",
        ]

    cmd = cmd_for(root)
    # an uninterrupted reference run gives the expected folders and files
    first = subprocess.run(cmd_for(tmp / "ref"), capture_output=True, text=True, check=False)
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    done_at_kill = 0
    while proc.poll() is None:
        done_at_kill = len(list(root.glob("*/" + MARKER)))
        if done_at_kill >= 9:
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.005)
    proc.wait()
    tmp_left = sorted(p.name for p in (root / ".tmp").glob("*")) if (root / ".tmp").exists() else []
    resumed = subprocess.run(cmd, capture_output=True, text=True, check=False)
    status = read_status(root)
    ref = read_status(tmp / "ref")
    folders = sorted(p.name for p in root.iterdir() if p.is_dir() and p.name != "summary")
    ref_folders = sorted(
        p.name for p in (tmp / "ref").iterdir() if p.is_dir() and p.name != "summary"
    )
    files = sorted(
        str(p.relative_to(root))
        for p in root.rglob("*")
        if p.is_file()
        and not p.name.startswith(".")
        and "summary" not in p.parts
        and p.name != BATCH_STATUS_TABLE.file
    )
    ref_files = sorted(
        str(p.relative_to(tmp / "ref"))
        for p in (tmp / "ref").rglob("*")
        if p.is_file()
        and not p.name.startswith(".")
        and "summary" not in p.parts
        and p.name != BATCH_STATUS_TABLE.file
    )
    failed = status[status["result"] == "failed"]
    return {
        "recordings": 20,
        "reference_exit_code": first.returncode,
        "reference_counts": ref["result"].value_counts().to_dict(),
        "finished_at_kill": done_at_kill,
        "tmp_folders_left_by_kill": tmp_left,
        "resume_exit_code": resumed.returncode,
        "resume_stdout": resumed.stdout.strip().splitlines()[0] if resumed.stdout else "",
        "final_counts": status["result"].value_counts().to_dict(),
        "skipped_on_resume": int((status["status"] == "skipped").sum()),
        "failed_reasons": dict(zip(failed["recording_id"], failed["error"], strict=True)),
        "status_rows": len(status),
        "unique_recordings": int(status["recording_id"].nunique()),
        "same_folders_as_uninterrupted_run": folders == ref_folders,
        "same_files_as_uninterrupted_run": files == ref_files,
        "tmp_left_after_resume": (root / ".tmp").exists(),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--recordings", type=int, default=8)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd")
    ap.add_argument("--ram", action="store_true", help="output roots in /dev/shm")
    ap.add_argument("--skip-kill", action="store_true", help="only the throughput part")
    ap.add_argument("--results", help="file name in benchmarks/results (e.g. on a loaded box)")
    ap.add_argument(
        "--synthetic",
        action="store_true",
        help="synthetic noisy frames (PNG-incompressible, as before) instead of real ones",
    )
    args = ap.parse_args()
    uptimes = [uptime()]
    ram = Path(tempfile.mkdtemp(prefix="bench_batch_", dir="/dev/shm")) if args.ram else None
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as name:
        tmp = Path(name)
        result: dict[str, object] = {
            "machine": f"{platform.machine()} {platform.python_version()}",
            "command": "python benchmarks/bench_batch.py " + " ".join(sys.argv[1:]),
            "throughput": throughput(
                tmp,
                args.recordings,
                args.frames,
                args.repeats,
                args.compression,
                ram,
                args.synthetic,
            ),
        }
        if not args.skip_kill:
            result["kill_and_resume"] = kill_and_resume(tmp)
    if ram is not None:
        shutil.rmtree(ram, ignore_errors=True)
    default = args.compression == "zstd" and not args.ram and not args.synthetic
    suffix = f"_{args.compression}" + ("_ram" if args.ram else "")
    suffix += "_synthetic" if args.synthetic else ""
    out = RESULTS if default else RESULTS.with_name(f"batch{suffix}.json")
    if args.results:
        out = RESULTS.with_name(args.results)
    result["uptime"] = [*uptimes, uptime()]
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1, default=str) + "\n")
    print(json.dumps(result, indent=1, default=str))


if __name__ == "__main__":
    main()
