"""Fuzz harness: damaged recordings, logs, DBCs, images, timestamps, paths and configs.

Each :class:`Case` builds its inputs in a fresh folder and names the ``slt`` command to run, the
exit codes that are correct for it, and a check of what must have been recovered (the data the
damage did not touch). :func:`run_case` runs the command in a forked child of a process that
has the toolkit imported already (so a case costs milliseconds, not an interpreter start), with
a timeout, and classifies the outcome: clean, traceback, internal error, hang, wrong exit code,
data lost beyond the damage, or files written outside ``--out``.

Inputs are built from real data where ``SLT_REALDATA`` has it (TuSimple frames, Ford Fusion
candump logs, the Mobileye DBC, the u-blox NMEA log, a real ROS 1 bag) and from the project's
own writers. ``tests/fuzz/test_fuzz.py`` runs a fast subset; ``benchmarks/fuzz.py`` the full
campaign and the SIGKILL campaign (:func:`kill_campaign`).
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import select
import shutil
import signal
import struct
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
T0 = 1_700_000_000_000_000_000
MS = 1_000_000
OUT = "out"
FINDINGS = (
    "clean",
    "traceback",
    "internal_error",
    "hang",
    "wrong_exit",
    "data_lost",
    "escaped_out",
)


def realdata() -> Path | None:
    """The real-data folder, or None when it is absent."""
    root = Path(os.environ.get("SLT_REALDATA", REPO.parent / "shared" / "data"))
    return root if (root / "README.md").is_file() else None


# -- what a run must have recovered ------------------------------------------------------------


def _rows(path: Path) -> int:
    import pyarrow.parquet as pq

    return int(pq.ParquetFile(path).metadata.num_rows) if path.is_file() else 0


def frames_ok(out: Path) -> int:
    """Frames extracted with ``ok`` and an existing file (each file counted once)."""
    import pyarrow.parquet as pq

    index = out / "frames.parquet"
    if not index.is_file():
        return 0
    table = pq.read_table(index, columns=["ok", "path"]).to_pydict()
    paths = {p for ok, p in zip(table["ok"], table["path"], strict=True) if ok and p}
    return sum(1 for p in paths if (out / p).is_file())


@dataclass(frozen=True)
class Need:
    """Minimum outputs of an extract: frames, CAN frames and GNSS fixes recovered."""

    frames: int = 0
    can: int = 0
    gnss: int = 0

    def check(self, out: Path) -> str | None:
        """Return what is missing beyond the damage, or None."""
        got = Need(frames_ok(out), _rows(out / "can_raw.parquet"), _rows(out / "rtk.parquet"))
        lost = [
            f"{name} {have} < {want}"
            for name, have, want in (
                ("frames", got.frames, self.frames),
                ("can", got.can, self.can),
                ("gnss", got.gnss, self.gnss),
            )
            if have < want
        ]
        return "; ".join(lost) or None


@dataclass(frozen=True)
class Case:
    """One fuzz case.

    Attributes:
        family: Kind of damage (the summary groups by it).
        name: Unique name.
        build: Writes the inputs into the case folder and returns the ``slt`` arguments.
        expect: Correct exit codes.
        need: Returns what the outputs must hold (None: no data check).
        file_size_limit: See below.
    """

    family: str
    name: str
    build: Callable[[Path], list[str]]
    expect: frozenset[int]
    need: Callable[[Path], str | None] | None = None
    file_size_limit: int | None = None
    """Largest file the run may write, bytes (``RLIMIT_FSIZE``: writes beyond it fail like a
    full disk, with ``EFBIG``)."""


@dataclass
class Outcome:
    """The result of one case: its findings (``clean`` alone when nothing was wrong)."""

    case: str
    family: str
    code: int | None
    seconds: float
    findings: list[str] = field(default_factory=list)
    detail: str = ""


# -- inputs ------------------------------------------------------------------------------------


_CACHE: dict[str, Any] = {}


def real_jpegs(n: int = 4, width: int = 96) -> list[bytes]:
    """JPEG frames from real TuSimple images (synthetic noise when the data is absent)."""
    key = f"jpegs{n}x{width}"
    if key not in _CACHE:
        import cv2
        import numpy as np

        root = realdata()
        images = []
        for i in range(n):
            src = root / "tusimple" / "frames" / f"{i % 6:04d}.png" if root else None
            img = cv2.imread(str(src)) if src is not None and src.is_file() else None
            if img is None:
                img = np.random.default_rng(i).integers(0, 255, (720, 1280, 3), dtype=np.uint8)
            img = cv2.resize(img, (width, width * 9 // 16))
            images.append(cv2.imencode(".jpg", img)[1].tobytes())
        _CACHE[key] = images
    return list(_CACHE[key])


def real_can(n: int = 400) -> list[tuple[float, int, bytes]]:
    """``(seconds, id, data)`` of real Ford Fusion frames (synthetic when absent)."""
    key = f"can{n}"
    if key not in _CACHE:
        frames: list[tuple[float, int, bytes]] = []
        root = realdata()
        src = root / "can_logs" / "ford_fusion" / "car_50km.log" if root else None
        if src is not None and src.is_file():
            for line in src.read_text(encoding="ascii", errors="replace").splitlines()[:n]:
                parts = line.split()
                ident, _, data = parts[2].partition("#")
                frames.append((float(parts[0].strip("()")), int(ident, 16), bytes.fromhex(data)))
        else:
            frames = [(i * 0.01, 0x100 + i % 7, bytes([i % 256] * 8)) for i in range(n)]
        _CACHE[key] = frames
    return list(_CACHE[key])


def write_drive(
    path: Path,
    fmt: str = "mcap",
    frames: int = 12,
    images: list[bytes] | None = None,
    times: list[int] | None = None,
    image_topics: tuple[str, ...] = ("/cam/compressed",),
    chunk_size: int = 16384,
) -> Need:
    """Write a drive (JPEG frames, CAN, RTK fixes) with the project's writers; return its size.

    Args:
        path: Output file (``.mcap``, ``.bag``) or ROS 2 bag folder.
        fmt: ``mcap``, ``ros1`` or ``ros2``.
        frames: Frames per image topic (one CAN frame and one fix per frame).
        images: Payloads to use instead of real JPEGs (cycled).
        times: Log times of the frames (default: 10 Hz from ``T0``).
        image_topics: Image topic names.
        chunk_size: MCAP chunk size, bytes.
    """
    from superlane_tools.recording.messages import can_frame, compressed_image, navsatfix
    from superlane_tools.recording.writers import open_writer

    payloads = images or real_jpegs()
    can = real_can(frames)
    stamps = times or [T0 + i * 100 * MS for i in range(frames)]
    kw: dict[str, Any] = {"chunk_size": chunk_size} if fmt == "mcap" else {}
    with open_writer(path, fmt, **kw) as w:  # type: ignore[arg-type]
        for topic in image_topics:
            w.add_topic(topic, "sensor_msgs/msg/CompressedImage")
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i, t in enumerate(stamps):
            st = t if t < 2**31 * 10**9 else T0  # header stamps hold int32 seconds
            for topic in image_topics:
                payload = payloads[i % len(payloads)]
                fmt_name = "png" if payload.startswith(b"\x89PNG") else "jpeg"
                w.write(topic, t, compressed_image(st, "cam", fmt_name, payload))
            _, ident, data = can[i % len(can)]
            w.write("/can", t, can_frame(st, ident, data))
            w.write("/fix", t, navsatfix(st, "gps", 48.0 + i * 1e-5, 11.0, 500.0, status=2))
    n = len(stamps)
    return Need(n * len(image_topics), n, n)


def candump_text(n: int = 400) -> bytes:
    """A real candump log (the first ``n`` lines of a Ford Fusion drive)."""
    lines = [f"({t:.6f}) can0 {ident:03X}#{data.hex().upper()}\n" for t, ident, data in real_can(n)]
    return "".join(lines).encode("ascii")


def nmea_text() -> bytes:
    """A real NMEA log (240 u-blox sentences) or a synthetic one when the data is absent."""
    root = realdata()
    src = root / "gnss" / "nmea.log" if root else None
    if src is not None and src.is_file():
        return src.read_bytes()
    out = []
    for i in range(60):
        rmc = f"GPRMC,1200{i:02d}.00,A,4807.038,N,01131.000,E,0.0,0.0,010124,,,A"
        gga = f"GPGGA,1200{i:02d}.00,4807.038,N,01131.000,E,4,12,0.9,545.4,M,46.9,M,,"
        for body in (rmc, gga):
            check = 0
            for ch in body.encode():
                check ^= ch
            out.append(f"${body}*{check:02X}\n")
    return "".join(out).encode("ascii")


def nmea_fixes(text: bytes) -> int:
    """Count the GGA sentences of a log (the fixes a reader yields)."""
    return sum(1 for line in text.splitlines() if b"GGA," in line)


def _flip(data: bytes, pos: int, mask: int = 0xFF) -> bytes:
    buf = bytearray(data)
    buf[pos] ^= mask or 1
    return bytes(buf)


def _garble(data: bytes, pos: int, rng: random.Random, n: int = 16) -> bytes:
    buf = bytearray(data)
    buf[pos : pos + n] = bytes(rng.randrange(256) for _ in range(min(n, len(buf) - pos)))
    return bytes(buf)


def _mcap_chunks(path: Path) -> list[tuple[int, int, int]]:
    """``(start_offset, end_offset, messages)`` of each chunk of a complete MCAP file."""
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        assert summary is not None
        out = []
        for ci in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            count = 0
            for offset in ci.message_index_offsets.values():
                handle.seek(offset)
                handle.read(9)
                head = handle.read(6)
                _channel, length = struct.unpack("<HI", head)
                count += length // 16
            out.append((ci.chunk_start_offset, ci.chunk_start_offset + ci.chunk_length, count))
    return out


# -- families ----------------------------------------------------------------------------------


def _extract(src: str, *extra: str) -> list[str]:
    return ["extract", src, "--out", OUT, *extra]


def mcap_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """Byte flips in the summary, cuts anywhere, and garbled chunks of an MCAP drive."""
    base_dir = Path(os.environ.get("SLT_FUZZ_CACHE", "/tmp")) / f"slt-fuzz-base-{os.getpid()}"
    base_dir.mkdir(parents=True, exist_ok=True)
    base = base_dir / "drive.mcap"
    full = write_drive(base, "mcap", frames=24, chunk_size=8192)
    data = base.read_bytes()
    chunks = _mcap_chunks(base)
    summary_start = struct.unpack_from("<Q", data, len(data) - 8 - 29 + 9)[0]
    per_message = {"frames": 1, "can": 1, "gnss": 1}
    del per_message
    for i in range(n):
        kind = ("summary", "cut", "chunk")[i % 3]
        if kind == "summary":
            pos = rng.randrange(summary_start, len(data))
            damaged = _flip(data, pos, rng.randrange(1, 256))
            name = f"mcap-summary-flip-{pos}"
            need: Need | None = full if pos < len(data) - 8 else None
            expect = frozenset({0, 3})
        elif kind == "cut":
            pos = rng.randrange(9, len(data))
            damaged = data[:pos]
            name = f"mcap-cut-{pos}"
            kept = sum(c for _, end, c in chunks if end <= pos)
            # messages of complete chunks: each chunk holds frames, CAN and fixes in turn
            need = Need(kept // 3 - 1, kept // 3 - 1, kept // 3 - 1) if kept >= 6 else None
            expect = frozenset({1, 3}) if pos < len(data) else frozenset({0})
        else:
            start, end, count = chunks[rng.randrange(len(chunks))]
            pos = rng.randrange(start + 40, max(start + 41, end - 4))
            damaged = _garble(data, pos, rng)
            name = f"mcap-chunk-garble-{pos}"
            lost = count // 3 + 1
            need = Need(full.frames - lost, full.can - lost, full.gnss - lost)
            expect = frozenset({0, 3})

        def build(work: Path, damaged: bytes = damaged) -> list[str]:
            (work / "d.mcap").write_bytes(damaged)
            return _extract("d.mcap")

        yield Case("mcap", name, build, expect, need.check if need else None)


def image_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """One bad frame among good ones: huge or tiny headers, cut JPEGs, random bytes."""
    import cv2
    import numpy as np

    good = real_jpegs()
    png = cv2.imencode(".png", np.zeros((4, 4, 3), np.uint8))[1].tobytes()
    huge_png = png[:16] + struct.pack(">II", 40000, 40000) + png[24:]
    sof = good[0].find(b"\xff\xc0")
    tall_jpeg = good[0][: sof + 5] + struct.pack(">HH", 60000, 1) + good[0][sof + 9 :]
    bads = {
        "huge-png": huge_png,
        "tall-jpeg": tall_jpeg,
        "cut-jpeg": good[1][: len(good[1]) // 2],
        "random": bytes(rng.randrange(256) for _ in range(2000)),
        "empty": b"",
        "png-magic-only": b"\x89PNG\r\n\x1a\n",
        "jpeg-magic-only": b"\xff\xd8\xff",
    }
    names = sorted(bads)
    for i in range(n):
        bad_name = names[i % len(names)]
        ok_exits = frozenset({0, 3}) if bad_name == "tall-jpeg" else frozenset({3})
        where = rng.randrange(12)
        fmt = ("mcap", "ros1", "ros2")[i % 3]
        images = [good[k % len(good)] for k in range(12)]
        images[where] = bads[bad_name]

        def build(work: Path, images: list[bytes] = images, fmt: str = fmt) -> list[str]:
            target = work / {"mcap": "d.mcap", "ros1": "d.bag", "ros2": "d2"}[fmt]
            write_drive(target, fmt, frames=12, images=images)
            return _extract(target.name)

        yield Case(
            "images",
            f"image-{bad_name}-{fmt}-{where}",
            build,
            ok_exits,
            Need(11, 12, 12).check,
        )


def time_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """Extreme but legal log times, shared log times, and out-of-range --start/--end."""
    extremes = [0, 1, 2**62, 2**63 - 1]
    for i in range(n):
        kind = i % 4
        if kind == 0:
            t0 = extremes[rng.randrange(len(extremes))]
            times = [min(t0 + k * 100 * MS, 2**63 - 1) for k in range(8)]
            times = sorted(set(times)) or [t0]
            name, expect, need = f"times-{t0}", frozenset({0}), Need(len(times), 0, 0)
        elif kind == 1:
            times = [T0 + (k // 3) * 100 * MS for k in range(9)]  # 3 frames per log time
            name, expect, need = f"times-shared-{i}", frozenset({0}), Need(9, 9, 9)
        elif kind == 2:
            times = [T0 + k * 100 * MS for k in range(6)] + [2**63 + k for k in range(3)]
            name, expect, need = f"times-beyond-int64-{i}", frozenset({3}), Need(6, 6, 6)
        else:
            bad = ("inf", "1e300", "nan", "-1", "1e20")[i // 4 % 5]
            times = [T0 + k * 100 * MS for k in range(4)]
            name, expect, need = f"times-option-{bad}", frozenset({2}), Need()

        def build(work: Path, times: list[int] = times, kind: int = kind, i: int = i) -> list[str]:
            if kind == 2:
                _write_raw_mcap(work / "d.mcap", times)
            else:
                write_drive(work / "d.mcap", "mcap", frames=len(times), times=times)
            if kind == 3:
                bad = ("inf", "1e300", "nan", "-1", "1e20")[i // 4 % 5]
                option = "--end" if i % 2 else "--start"
                return _extract("d.mcap", option, bad)
            return _extract("d.mcap")

        yield Case("timestamps", name, build, expect, need.check)


def _write_raw_mcap(path: Path, times: list[int]) -> None:
    """An MCAP drive whose messages carry the given log times (up to 2^64 - 1, as MCAP allows).

    The drive is written with the project's writer, then copied record by record with the
    mcap writer, replacing each message's log time (one time per frame, CAN frame and fix).
    """
    from mcap.reader import make_reader
    from mcap.writer import Writer

    plain = path.with_suffix(".plain.mcap")
    write_drive(plain, "mcap", frames=len(times))
    with plain.open("rb") as fin, path.open("wb") as fout:
        reader = make_reader(fin)
        writer = Writer(fout)
        writer.start()
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        seen: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if schema is not None and schema.id not in schema_ids:
                schema_ids[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channel_ids:
                channel_ids[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schema_ids.get(channel.schema_id, 0)
                )
            k = seen.get(channel.id, 0)
            seen[channel.id] = k + 1
            writer.add_message(
                channel_ids[channel.id], times[k], message.data, times[k], message.sequence
            )
        writer.finish()
    plain.unlink()


def topic_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """Image topics whose folder names collide, and very long topic names."""
    sets = [
        ("/cam/front", "/cam_front", "cam/front/"),
        ("/cam/\u00e4", "/cam/\u00f6"),
        ("/" + "x" * 300,),
        ("/" + "a" * 250, "/" + "a" * 250 + "b"),
        ("/cam/front", "/CAM/FRONT"),
        ("/.", "/..", "/..."),
    ]
    for i in range(n):
        topics = sets[i % len(sets)]
        fmt = ("mcap", "ros2")[i // len(sets) % 2]

        def build(work: Path, topics: tuple[str, ...] = topics, fmt: str = fmt) -> list[str]:
            target = work / ("d.mcap" if fmt == "mcap" else "d2")
            write_drive(target, fmt, frames=5, image_topics=topics)
            return _extract(target.name)

        yield Case(
            "topics", f"topics-{i}-{fmt}", build, frozenset({0}), Need(5 * len(topics)).check
        )


def canlog_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """candump logs with bad first lines, NUL bytes, huge and late frames, garbled lines."""
    text = candump_text()
    lines = text.splitlines(keepends=True)
    heads = [
        b"# candump -l can0\n",
        b"\x00\x01\x02\xff\xfe binary\n",
        b"(12.5) can0 12#zz\n",
        b"\x00" * 64 + b"\n",
        b"garbage line without anything\n",
        b"\xef\xbb\xbf# bom\n",
    ]
    for i in range(n):
        kind = i % 4
        body = list(lines)
        if kind == 0:
            head = heads[rng.randrange(len(heads))]
            data, want, name = head + text, len(lines), f"candump-head-{i}"
        elif kind == 1:
            k = rng.randrange(len(body))
            body[k] = b"(1.000000) can0 123#" + b"AB" * rng.choice([65, 1000, 250000]) + b"\n"
            data, want, name = b"".join(body), len(lines) - 1, f"candump-huge-{k}"
        elif kind == 2:
            k = rng.randrange(1, len(body))
            body.insert(k, f"({rng.choice(['1e20', '99999999999999', '0'])}) can0 1#00\n".encode())
            data, want, name = b"".join(body), len(lines), f"candump-late-{k}"
        else:
            hits = rng.sample(range(len(body)), 5)
            for k in hits:  # garble inside the line, never its newline
                body[k] = _garble(body[k][:-1], rng.randrange(len(body[k]) - 1), rng, 3) + b"\n"
            data, want, name = b"".join(body), len(lines) - 5, f"candump-garble-{i}"

        def build(work: Path, data: bytes = data) -> list[str]:
            (work / "d.log").write_bytes(data)
            return _extract("d.log")

        yield Case("canlog", name, build, frozenset({0, 3}), Need(0, want, 0).check)


def blf_asc_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """Garbled and truncated BLF files, ASC files with bytes that are not ASCII."""
    import can

    frames = real_can(3000)
    cache = Path(os.environ.get("SLT_FUZZ_CACHE", "/tmp")) / f"slt-fuzz-base-{os.getpid()}"
    cache.mkdir(parents=True, exist_ok=True)
    files = {}
    for ext in ("blf", "asc"):
        path = cache / f"d.{ext}"
        with can.Logger(path) as log:
            for t, ident, data in frames:
                log.on_message_received(can.Message(timestamp=t, arbitration_id=ident, data=data))
        files[ext] = path.read_bytes()
    blf = files["blf"]
    containers = _blf_containers(blf)
    for i in range(n):
        kind = i % 3
        if kind == 0:
            pos = rng.randrange(144, len(blf))
            data, name = _garble(blf, pos, rng), f"blf-garble-{pos}"
            want = sum(c for s, e, c in containers if e <= pos or s >= pos + 16)
            ext = "blf"
        elif kind == 1:
            pos = rng.randrange(144, len(blf))
            data, name = blf[:pos], f"blf-cut-{pos}"
            want = sum(c for _, e, c in containers if e <= pos)
            ext = "blf"
        else:
            asc = files["asc"]
            pos = rng.randrange(len(asc))
            data = asc[:pos] + bytes([rng.randrange(128, 256)]) + asc[pos + 1 :]
            name, want, ext = f"asc-byte-{pos}", len(frames) - 1, "asc"

        def build(work: Path, data: bytes = data, ext: str = ext) -> list[str]:
            (work / f"d.{ext}").write_bytes(data)
            return _extract(f"d.{ext}")

        expect = frozenset({0, 3}) if kind == 2 else frozenset({1, 3})
        yield Case("blf_asc", name, build, expect, Need(0, want, 0).check if want else None)


def _blf_containers(data: bytes) -> list[tuple[int, int, int]]:
    """``(start, end, frames)`` of each container object of an intact BLF file."""
    import zlib

    out = []
    pos = struct.unpack_from("<I", data, 4)[0]
    while pos + 16 <= len(data):
        sig, _, _, size, kind = struct.unpack_from("<4sHHII", data, pos)
        if sig != b"LOBJ":
            break
        if kind == 10:
            payload = data[pos + 32 : pos + size]
            raw = zlib.decompress(payload) if data[pos + 16] == 2 else payload
            out.append((pos, pos + size, raw.count(b"LOBJ")))
        pos += size + size % 4
    # objects that straddle two containers belong to neither alone: count them conservatively
    return [(s, e, max(0, c - 1)) for s, e, c in out]


def nmea_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """NMEA logs with bad first lines, NUL bytes, garbled sentences, odd fix qualities."""
    text = nmea_text()
    lines = text.splitlines(keepends=True)
    fixes = nmea_fixes(text)
    for i in range(n):
        kind = i % 3
        body = list(lines)
        if kind == 0:
            head = (b"# log\n", b"\x00\x00\n", b"$GPGGA,junk*00\n", b"\xff\xfe\n")[i // 3 % 4]
            data, want, name = head + text, fixes, f"nmea-head-{i}"
        elif kind == 1:
            hits = rng.sample(range(2, len(body)), 4)
            for k in hits:
                line = body[k].rstrip(b"\r\n")
                body[k] = _garble(line, rng.randrange(1, len(line)), rng, 2) + b"\r\n"
            data, want, name = b"".join(body), fixes - 4, f"nmea-garble-{i}"
        else:
            k = next(j for j, line in enumerate(body) if b"GGA," in line)
            fields = body[k].split(b"*")[0].split(b",")
            fields[6] = str(rng.choice([9, 200, 255, 99999])).encode()
            sentence = b",".join(fields)[1:]
            check = 0
            for ch in sentence:
                check ^= ch
            body[k] = b"$" + sentence + f"*{check:02X}\n".encode()
            data, want, name = b"".join(body), fixes - 1, f"nmea-quality-{i}"

        def build(work: Path, data: bytes = data) -> list[str]:
            (work / "fixes.log").write_bytes(data)
            return _extract("fixes.log")

        yield Case("nmea", name, build, frozenset({0, 3}), Need(0, 0, want).check)


def dbc_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """Mutated real DBCs: negative start bits, unindented duplicate signals, lines dropped."""
    root = realdata()
    src = root / "dbc" / "opendbc" if root else None
    texts = []
    if src is not None and src.is_dir():
        texts = [p.read_bytes() for p in sorted(src.glob("ford_lincoln_base_pt.dbc"))]
    if root is not None and (root / "dbc" / "mobileye" / "Mobileye.dbc").is_file():
        texts.append((root / "dbc" / "mobileye" / "Mobileye.dbc").read_bytes())
    if not texts:
        texts = [b'VERSION ""\nBU_: A\nBO_ 1045 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] "" A\n']
    log = candump_text(200)
    for i in range(n):
        text = texts[i % len(texts)]
        lines = text.splitlines(keepends=True)
        kind = i % 5
        if kind == 0:
            k = rng.choice([j for j, line in enumerate(lines) if b"SG_ " in line] or [0])
            lines[k] = lines[k].replace(b": ", b": -", 1)
        elif kind == 1:
            sg = [j for j, line in enumerate(lines) if line.lstrip().startswith(b"SG_ ")]
            lines = [line.lstrip() if line.lstrip().startswith(b"SG_ ") else line for line in lines]
            if sg:
                lines.insert(sg[0] + 1, lines[sg[0]])
        elif kind == 2:
            for _ in range(5):
                del lines[rng.randrange(len(lines))]
        elif kind == 3:
            k = rng.randrange(len(lines))
            lines[k] = _garble(lines[k], rng.randrange(max(1, len(lines[k]))), rng, 4)
        else:
            lines = lines[: rng.randrange(1, len(lines))]
        data = b"".join(lines)

        def build(work: Path, data: bytes = data) -> list[str]:
            (work / "x.dbc").write_bytes(data)
            (work / "d.log").write_bytes(log)
            return _extract("d.log", "--dbc", "x.dbc")

        yield Case("dbc", f"dbc-{kind}-{i}", build, frozenset({0, 1, 3}), None)


def bag_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """ROS 1 bags and ROS 2 sqlite3 bags, cut or with flipped bytes or zeroed pages."""
    cache = Path(os.environ.get("SLT_FUZZ_CACHE", "/tmp")) / f"slt-fuzz-base-{os.getpid()}"
    cache.mkdir(parents=True, exist_ok=True)
    bag = cache / "d.bag"
    write_drive(bag, "ros1", frames=24)
    ros2 = cache / "d2"
    if not ros2.exists():
        write_drive(ros2, "ros2", frames=24)
    db3 = next(ros2.glob("*.db3"))
    bag_data, db3_data = bag.read_bytes(), db3.read_bytes()
    for i in range(n):
        kind = i % 4
        if kind == 0:
            pos = rng.randrange(13, len(bag_data))
            files, name = {"d.bag": bag_data[:pos]}, f"ros1-cut-{pos}"
        elif kind == 1:
            pos = rng.randrange(13, len(bag_data))
            files, name = {"d.bag": _flip(bag_data, pos)}, f"ros1-flip-{pos}"
        elif kind == 2:
            page = rng.randrange(1, max(2, len(db3_data) // 4096))
            buf = bytearray(db3_data)
            buf[page * 4096 : (page + 1) * 4096] = bytes(4096)
            files, name = {"d.db3": bytes(buf)}, f"db3-zero-page-{page}"
        else:
            pos = rng.randrange(4096, len(db3_data))
            files, name = {"d.db3": db3_data[:pos]}, f"db3-cut-{pos}"

        def build(work: Path, files: dict[str, bytes] = files) -> list[str]:
            for fname, content in files.items():
                (work / fname).write_bytes(content)
            return _extract(next(iter(files)))

        expect = frozenset({1, 3}) if kind in {0, 3} else frozenset({0, 1, 3})
        yield Case("bags", name, build, expect, None)


def path_config_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """Odd paths (FIFOs, folders, files as --out, missing files) and configs of wrong types."""
    variants: list[tuple[str, Callable[[Path], list[str]], frozenset[int]]] = []

    def drive(work: Path) -> None:
        write_drive(work / "d.mcap", "mcap", frames=4)

    def fifo_rec(work: Path) -> list[str]:
        os.mkfifo(work / "d.mcap")
        return _extract("d.mcap")

    def fifo_dbc(work: Path) -> list[str]:
        drive(work)
        os.mkfifo(work / "x.dbc")
        return _extract("d.mcap", "--dbc", "x.dbc")

    def out_is_file(work: Path) -> list[str]:
        drive(work)
        (work / OUT).write_text("x")
        return _extract("d.mcap")

    def reprocess_out_is_file(work: Path) -> list[str]:
        drive(work)
        (work / OUT).write_text("x")
        return ["reprocess", "d.mcap", "--out", OUT, "--no-plots"]

    def missing(work: Path) -> list[str]:
        return _extract("nope.mcap")

    def folder(work: Path) -> list[str]:
        (work / "dir.mcap").mkdir()
        return _extract("dir.mcap")

    def config(text: str) -> Callable[[Path], list[str]]:
        def build(work: Path) -> list[str]:
            drive(work)
            (work / "c.yaml").write_text(text)
            return _extract("d.mcap", "--config", "c.yaml")

        return build

    def tables_of(work: Path) -> list[str]:
        (work / OUT).mkdir()
        (work / OUT / "availability_sequences.parquet").write_bytes(b"PAR1")
        return ["tables", "availability", OUT]

    def unicode_out(work: Path) -> list[str]:
        drive(work)
        return ["extract", "d.mcap", "--out", f"{OUT}/\u00e4 b c/\u65e5\u672c"]

    variants += [
        ("fifo-recording", fifo_rec, frozenset({1})),
        ("fifo-dbc", fifo_dbc, frozenset({1})),
        ("out-is-file", out_is_file, frozenset({2})),  # an existing output: refused (exit 2)
        ("reprocess-out-is-file", reprocess_out_is_file, frozenset({2})),
        ("missing", missing, frozenset({1, 2})),
        ("folder", folder, frozenset({1})),
        ("config-list", config("- frames\n- can\n"), frozenset({2})),
        ("config-banana", config("frames: {a: 1}\n"), frozenset({2})),
        ("config-every", config("every: banana\n"), frozenset({2})),
        ("config-binary", config("\x00\x01\x02"), frozenset({2})),
        ("tables-incomplete", tables_of, frozenset({1})),
        ("unicode-out", unicode_out, frozenset({0})),
    ]
    for i in range(n):
        name, build, expect = variants[i % len(variants)]
        yield Case("paths_configs", f"{name}-{i}", build, expect, None)


def _rewrite_mcap(src: Path, dst: Path, edit: Callable[[str, int, int, Any], Any]) -> None:
    """Copy an MCAP file message by message; ``edit(topic, index, log_time, msg)`` may return
    a replacement ``(log_time, msg)`` for a decoded ROS 2 message (None keeps it)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    from superlane_tools.recording.typestore import default_typestore

    store = default_typestore()
    with src.open("rb") as fin, dst.open("wb") as fout:
        reader = make_reader(fin)
        writer = Writer(fout)
        writer.start()
        summary = reader.get_summary()
        assert summary is not None
        for meta in reader.iter_metadata():
            writer.add_metadata(meta.name, meta.metadata)
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        seen: dict[str, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if schema is not None and schema.id not in schema_ids:
                schema_ids[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channel_ids:
                channel_ids[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schema_ids.get(channel.schema_id, 0),
                    channel.metadata,
                )
            index = seen.get(channel.topic, 0)
            seen[channel.topic] = index + 1
            t, data = message.log_time, message.data
            msgtype = (
                f"{schema.name.split('/')[0]}/msg/{schema.name.split('/')[-1]}" if schema else ""
            )
            if msgtype in store.fielddefs:
                changed = edit(
                    channel.topic,
                    index,
                    t,
                    lambda d=data, m=msgtype: store.deserialize_cdr(d, m),
                )
                if changed is not None:
                    t, msg = changed
                    data = bytes(store.serialize_cdr(msg, msgtype))
            writer.add_message(channel_ids[channel.id], t, data, t, message.sequence)
        writer.finish()


def reprocess_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """``slt reprocess`` on drives with one bad frame or frames sharing log times."""
    from dataclasses import replace

    import numpy as np

    good = real_jpegs()
    sof = good[0].find(b"\xff\xc0")
    tall = good[0][: sof + 5] + struct.pack(">HH", 60000, 1) + good[0][sof + 9 :]
    png = __import__("cv2").imencode(".png", np.zeros((4, 4, 3), np.uint8))[1].tobytes()
    huge = png[:16] + struct.pack(">II", 40000, 40000) + png[24:]
    kinds = ["tall-jpeg", "shared-times", "huge-png", "duplicate-times", "random"]
    for i in range(n):
        kind = kinds[i % len(kinds)]
        where = rng.randrange(2, 28)

        def build(work: Path, kind: str = kind, where: int = where) -> list[str]:
            from superlane_tools.simulation.drive import simulate_drive

            plain = work / "plain.mcap"
            simulate_drive("highway_curves", 2.0, 3, "mcap", 160, 90, False, plain)

            def edit(topic: str, index: int, t: int, decode: Callable[[], Any]) -> Any:
                if topic != "/camera/image/compressed":
                    return None
                if kind == "shared-times":  # a bridge batching 3 frames per log time
                    return (t - (index % 3) * 66_666_667, decode())
                if kind == "duplicate-times":
                    return (t - 66_666_667, decode()) if index == where else None
                if index != where:
                    return None
                payload = {"tall-jpeg": tall, "huge-png": huge}.get(kind)
                if payload is None:
                    payload = bytes(rng.randrange(256) for _ in range(3000))
                msg = decode()
                return (t, replace(msg, data=np.frombuffer(payload, np.uint8)))

            _rewrite_mcap(plain, work / "d.mcap", edit)
            plain.unlink()
            return ["reprocess", "d.mcap", "--out", OUT, "--no-plots"]

        bad_frame = kind not in {"shared-times", "duplicate-times"}

        def need(out: Path, bad_frame: bool = bad_frame) -> str | None:
            from superlane_tools.reporting.run_folder import require_complete_run

            try:
                require_complete_run(out)
            except Exception as err:
                return str(err)
            frames = _rows(out / "frames.parquet")
            want = 29 if bad_frame else 30
            return None if frames >= want else f"frames {frames} < {want}"

        expect = frozenset({3}) if bad_frame else frozenset({0, 3})
        yield Case("reprocess", f"reprocess-{kind}-{i}", build, expect, need)


def disk_full_cases(rng: random.Random, n: int) -> Iterator[Case]:
    """extract, reprocess and batch when every file write past a size fails (a full disk)."""
    for i in range(n):
        command = ("extract", "reprocess", "batch")[i % 3]
        limit = rng.choice([0, 2_000, 20_000, 200_000])

        def build(work: Path, command: str = command) -> list[str]:
            if command == "reprocess":
                from superlane_tools.simulation.drive import simulate_drive

                simulate_drive("highway_curves", 1.0, 3, "mcap", 160, 90, False, work / "d.mcap")
                return ["reprocess", "d.mcap", "--out", OUT, "--no-plots"]
            write_drive(work / "d.mcap", "mcap", frames=8)
            if command == "batch":
                return ["batch", "d.mcap", "--out", OUT, "--job", "extract", "--workers", "1"]
            return _extract("d.mcap")

        def clean(out: Path) -> str | None:
            stray = leftovers(out.parent)
            return f"left behind: {stray[:3]}" if stray else None

        yield Case(
            "disk_full",
            f"disk-full-{command}-{limit}-{i}",
            build,
            frozenset({0, 1, 3}),
            clean,
            file_size_limit=limit + 1,
        )


FAMILIES: dict[str, Callable[[random.Random, int], Iterator[Case]]] = {
    "disk_full": disk_full_cases,
    "reprocess": reprocess_cases,
    "mcap": mcap_cases,
    "images": image_cases,
    "timestamps": time_cases,
    "topics": topic_cases,
    "canlog": canlog_cases,
    "blf_asc": blf_asc_cases,
    "nmea": nmea_cases,
    "dbc": dbc_cases,
    "bags": bag_cases,
    "paths_configs": path_config_cases,
}


def all_cases(per_family: dict[str, int], seed: int = 0) -> list[Case]:
    """Build the cases: ``per_family`` maps a family name to its number of cases."""
    out: list[Case] = []
    for family, count in per_family.items():
        rng = random.Random(f"{seed}-{family}")
        out.extend(FAMILIES[family](rng, count))
    return out


# -- running -----------------------------------------------------------------------------------


def preload() -> None:
    """Import what the commands use, once, so that forked children start warm."""
    import cantools  # noqa: F401
    import cv2  # noqa: F401
    import mcap_ros2.decoder  # noqa: F401
    import pyarrow.parquet  # noqa: F401
    import rosbags.rosbag1
    import rosbags.rosbag2  # noqa: F401

    import superlane_tools.cli.app
    import superlane_tools.commands.extract  # noqa: F401
    from superlane_tools.recording.typestore import default_typestore

    default_typestore()


def _listing(folder: Path, skip: set[str]) -> set[str]:
    out = set()
    for root, dirs, files in os.walk(folder):
        rel = Path(root).relative_to(folder)
        if rel.parts and rel.parts[0] in skip:
            continue
        dirs[:] = [d for d in dirs if not (not rel.parts and d in skip)]
        out.update(str(rel / f) for f in files)
        out.update(str(rel / d) + "/" for d in dirs)
    return out


def run_case(case: Case, root: Path, timeout_s: float = 60.0) -> Outcome:
    """Build and run one case in ``root/<name>`` (forked child, with a timeout); classify it."""
    work = root / case.name.replace("/", "_")[:120]
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    try:
        args = case.build(work)
    except Exception as err:  # the generator itself failed: report, do not hide
        return Outcome(case.name, case.family, None, 0.0, ["harness_error"], repr(err)[:200])
    before = _listing(work, {OUT})
    err_path = work.parent / f".{work.name}.stderr"
    t0 = time.perf_counter()
    if args[0] == "batch":  # its process pool re-imports __main__: run it as a real program
        code, hung = _run_program(args, work, err_path, timeout_s, case.file_size_limit)
        return _classify(case, work, before, err_path, code, hung, time.perf_counter() - t0)
    pid = os.fork()
    if pid == 0:  # child: run the CLI exactly as the console script does
        code = 1
        try:
            os.chdir(work)
            fd = os.open(err_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            os.dup2(fd, 2)
            sys.stdout = io.TextIOWrapper(os.fdopen(1, "wb", closefd=False), write_through=True)
            sys.stderr = io.TextIOWrapper(os.fdopen(2, "wb", closefd=False), write_through=True)
            os.environ["COLUMNS"] = "400"
            if case.file_size_limit is not None:
                import resource

                signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
                limit = case.file_size_limit
                resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
            sys.argv = ["slt", *args]
            from superlane_tools.cli.app import main

            try:
                main()
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except BaseException:  # a traceback escaping main(): print it for the parent
            import traceback

            traceback.print_exc()
            code = 99
        finally:
            with contextlib.suppress(Exception):
                sys.stderr.flush()
            os._exit(code)
    code, hung = _wait(pid, timeout_s)
    return _classify(case, work, before, err_path, code, hung, time.perf_counter() - t0)


def _run_program(
    args: list[str], work: Path, err_path: Path, timeout_s: float, limit: int | None
) -> tuple[int | None, bool]:
    def limit_files() -> None:
        if limit is not None:
            import resource

            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = dict(os.environ, PYTHONPATH=str(REPO), COLUMNS="400")
    with err_path.open("wb") as err:
        proc = subprocess.Popen(
            [sys.executable, "-c", "from superlane_tools.cli.app import main; main()", *args],
            cwd=work,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=err,
            preexec_fn=limit_files,  # noqa: PLW1509 - only setrlimit, no threads yet
            start_new_session=True,
        )
        try:
            return proc.wait(timeout=timeout_s), False
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            return None, True


def _classify(
    case: Case,
    work: Path,
    before: set[str],
    err_path: Path,
    code: int | None,
    hung: bool,
    seconds: float,
) -> Outcome:
    stderr = err_path.read_text(encoding="utf-8", errors="replace") if err_path.exists() else ""
    err_path.unlink(missing_ok=True)
    findings = []
    if hung:
        findings.append("hang")
    if "Traceback (most recent call last)" in stderr:
        findings.append("traceback")
    if "internal error" in stderr:
        findings.append("internal_error")
    if not hung and code not in case.expect:
        findings.append("wrong_exit")
    if not hung and case.need is not None and (code in {0, 3} or case.family == "disk_full"):
        lost = case.need(work / OUT)
        if lost:
            findings.append("data_lost")
            stderr = f"{lost}\n{stderr}"
    escaped = _listing(work, {OUT}) - before
    if escaped:
        findings.append("escaped_out")
        stderr = f"outside --out: {sorted(escaped)[:5]}\n{stderr}"
    outcome = Outcome(
        case.name, case.family, code, seconds, findings or ["clean"], stderr.strip()[-400:]
    )
    if findings == []:
        shutil.rmtree(work, ignore_errors=True)
    return outcome


def _wait(pid: int, timeout_s: float) -> tuple[int | None, bool]:
    deadline = time.monotonic() + timeout_s
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return os.waitstatus_to_exitcode(status), False
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return None, True
        select.select([], [], [], 0.01)


def summarise(outcomes: list[Outcome]) -> dict[str, Any]:
    """The summary table: cases, clean, and the count of each finding, overall and by family."""

    def table(items: list[Outcome]) -> dict[str, int]:
        row = {"cases": len(items)}
        for name in (*FINDINGS, "harness_error"):
            row[name] = sum(1 for o in items if name in o.findings)
        return row

    families = sorted({o.family for o in outcomes})
    return {
        "total": table(outcomes),
        "by_family": {f: table([o for o in outcomes if o.family == f]) for f in families},
    }


# -- SIGKILL campaign --------------------------------------------------------------------------


@dataclass
class KillOutcome:
    """One kill-and-rerun trial."""

    command: str
    kill_after_s: float
    killed: bool
    rerun_code: int | None
    problems: list[str]


def _slt(args: list[str], cwd: Path, capture: bool = False) -> subprocess.Popen[bytes]:
    env = dict(os.environ, PYTHONPATH=str(REPO), COLUMNS="400")
    return subprocess.Popen(
        [sys.executable, "-c", "from superlane_tools.cli.app import main; main()", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE if capture else subprocess.DEVNULL,
        start_new_session=True,
    )


def leftovers(folder: Path) -> list[str]:
    """Temporary files and folders (``.*.tmp``, staging, ``.old``) anywhere under ``folder``."""
    found = []
    for root, dirs, files in os.walk(folder):
        if Path(root).name == ".tmp" and not dirs and not files:
            continue
        for name in [*dirs, *files]:
            if name == ".tmp":  # the batch work folder itself; its contents are checked
                continue
            if name.startswith(".") and (
                name.endswith((".tmp", ".old")) or ".slt-staging." in name or ".slt-old." in name
            ):
                found.append(str(Path(root, name).relative_to(folder)))
    return found


def check_run(command: str, work: Path, need: Need) -> list[str]:
    """What is wrong with the outputs of a completed command (empty: complete and clean)."""
    problems: list[str] = []
    out = work / OUT
    if command == "reprocess":
        from superlane_tools.reporting.run_folder import require_complete_run

        try:
            require_complete_run(out)
        except Exception as err:
            problems.append(f"incomplete run: {err}")
    elif command == "extract":
        lost = need.check(out)
        if lost:
            problems.append(f"lost: {lost}")
    else:  # batch
        folders = [
            p for p in out.iterdir() if p.is_dir() and not p.name.startswith((".", "summary"))
        ]
        if len(folders) != 2 or not all((p / ".slt_batch.json").is_file() for p in folders):
            problems.append(f"batch folders incomplete: {[p.name for p in folders]}")
        if not (out / "summary" / "report.html").is_file():
            problems.append("no batch summary")
    stray = leftovers(work)
    if stray:
        problems.append(f"left behind: {stray[:5]}")
    return problems


def kill_campaign(
    command: str, trials: int, root: Path, seed: int = 0, timeout_s: float = 300.0
) -> list[KillOutcome]:
    """SIGKILL ``slt <command>`` at random moments, rerun it, and check the outputs.

    ``extract`` and ``reprocess`` run on one drive, ``batch`` (extract jobs) on two;
    ``batch-ray`` is that batch on the ray engine, where only the driver is killed (as the OOM
    killer would) and every process it had started (Ray's included) must be gone when the rerun
    ends. Each trial
    kills the process group after a random time within the measured duration of a full run
    (a previous complete output is in place for half of the trials), then reruns the same
    command to completion and checks that the outputs are complete and consistent and that
    nothing temporary was left anywhere in the case folder.
    """
    from superlane_tools.commands.batch._ray_watchdog import alive, descendants

    rng = random.Random(f"kill-{seed}-{command}")
    work = root / f"kill-{command}"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    need = write_drive(work / "d.mcap", "mcap", frames=30)
    if command == "reprocess":  # a drive with camera calibration, as reprocess needs
        from superlane_tools.simulation.drive import simulate_drive

        (work / "d.mcap").unlink()
        simulate_drive("highway_curves", 2.0, 3, "mcap", 160, 90, False, work / "d.mcap")
    if command.startswith("batch"):
        (work / "recs").mkdir()
        shutil.copy(work / "d.mcap", work / "recs" / "a.mcap")
        write_drive(work / "recs" / "b.mcap", "mcap", frames=20, times=None)
        (work / "c.toml").write_text('frame_format = "jpg"\n')
        args = ["batch", "recs", "--out", OUT, "--job", "extract", "--config", "c.toml", "--force"]
        args += ["--workers", "1"]
        if command == "batch-ray":
            args += ["--engine", "ray"]
    elif command == "reprocess":  # reruns replace the previous output: --overwrite
        args = ["reprocess", "d.mcap", "--out", OUT, "--no-plots", "--overwrite"]
    else:
        args = ["extract", "d.mcap", "--out", OUT, "--overwrite"]
    t0 = time.perf_counter()
    proc = _slt(args, work)
    proc.wait(timeout=timeout_s)
    full_s = time.perf_counter() - t0
    outcomes = []
    for trial in range(trials):
        if trial % 2 and (work / OUT).exists():
            shutil.rmtree(work / OUT)  # half the trials into a fresh folder
        delay = rng.uniform(0.05, 0.8 * full_s)  # runs vary: stay inside most of them
        proc = _slt(args, work)
        started: list[int] = []
        try:
            proc.wait(timeout=delay)
            killed = False
        except subprocess.TimeoutExpired:
            if command == "batch-ray":
                started = descendants(proc.pid)
                os.kill(proc.pid, signal.SIGKILL)
            else:
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            killed = True
        problems = []
        if (work / OUT).exists() and command == "reprocess":
            from superlane_tools.reporting.run_folder import RUN_MANIFEST

            if not (work / OUT / RUN_MANIFEST).is_file():
                problems.append("after the kill --out holds an incomplete run")
        rerun = _slt(args, work, capture=True)
        _, err = rerun.communicate(timeout=timeout_s)
        if rerun.returncode != 0:
            problems.append(f"rerun exit {rerun.returncode}: {err.decode()[-200:]}")
        problems += check_run(command, work, need if command == "extract" else Need())
        if survivors := [p for p in started if alive(p)]:  # Ray's processes too
            problems.append(f"processes of the killed run still running: {survivors}")
        outcomes.append(KillOutcome(command, round(delay, 3), killed, rerun.returncode, problems))
    return outcomes
