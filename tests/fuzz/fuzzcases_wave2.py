"""Fuzz generators of the second wave of bad inputs (issue 27 item 8).

ROS 2 sqlite3 damage (truncated at fractions, zeroed and garbage pages, junk or empty ``-wal``
and ``-shm`` files), binary junk in every text log (NMEA, candump, ASC, CSV, GPX), topics of the
wrong kind in every topic option and config key, malformed batch manifests, and ``slt recover``
on every damaged kind (its output must read back equal to what ``slt cat`` reads from the
damaged input). The harness (``run_case``, ``Case``, the base drives) is ``fuzzcases``.
"""

from __future__ import annotations

import os
import random
from collections.abc import Callable, Iterator
from pathlib import Path

import fuzzcases as fc

PAGE = 4096
JUNK = bytes(random.Random(27).randrange(256) for _ in range(64))


def _base() -> Path:
    """The cache folder of the base recordings (written once per process)."""
    cache = Path(os.environ.get("SLT_FUZZ_CACHE", "/tmp")) / f"slt-fuzz-w2-{os.getpid()}"
    cache.mkdir(parents=True, exist_ok=True)
    return cache


def _ros2_db3() -> bytes:
    folder = _base() / "d2"
    if not folder.exists():
        fc.write_drive(folder, "ros2", frames=24)
    return next(folder.glob("*.db3")).read_bytes()


def _mcap() -> bytes:
    path = _base() / "d.mcap"
    if not path.exists():
        fc.write_drive(path, "mcap", frames=24, chunk_size=4096)
    return path.read_bytes()


def _ros1() -> bytes:
    path = _base() / "d.bag"
    if not path.exists():
        fc.write_drive(path, "ros1", frames=24)
    return path.read_bytes()


def _files_case(
    family: str,
    name: str,
    files: dict[str, bytes],
    args: list[str],
    expect: frozenset[int],
    need: Callable[[Path], str | None] | None = None,
) -> fc.Case:
    def build(work: Path) -> list[str]:
        for fname, content in files.items():
            (work / fname).write_bytes(content)
        (work / fc.OUT).mkdir(exist_ok=True)
        return list(args)

    return fc.Case(family, name, build, expect, need)


# -- ROS 2 sqlite3 damage ----------------------------------------------------------------------


def sqlite_damage(rng: random.Random, i: int, db3: bytes) -> tuple[str, dict[str, bytes]]:
    """One damaged ``d.db3`` (and maybe ``-wal``/``-shm`` files): ``(name, files)``."""
    kind = i % 7
    pages = max(2, len(db3) // PAGE)
    if kind == 0:
        frac = (0.05, 0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9, 0.99)[i // 7 % 9]
        return f"db3-cut-{frac}", {"d.db3": db3[: int(len(db3) * frac)]}
    if kind in (1, 2):
        page = rng.randrange(1, pages)
        buf = bytearray(db3)
        fill = bytes(PAGE) if kind == 1 else rng.randbytes(PAGE)
        buf[page * PAGE : (page + 1) * PAGE] = fill
        return f"db3-{'zero' if kind == 1 else 'garbage'}-page-{page}-{i}", {"d.db3": bytes(buf)}
    if kind == 3:  # the header page itself
        pos = rng.randrange(16, 100)
        return f"db3-header-flip-{pos}", {"d.db3": fc._flip(db3, pos)}
    side = {"d.db3": db3}
    if kind == 4:
        side["d.db3-wal"] = rng.randbytes(rng.choice([8, 32, PAGE, 3 * PAGE]))
        return f"db3-junk-wal-{i}", side
    if kind == 5:
        side["d.db3-shm"] = rng.randbytes(rng.choice([8, 32768]))
        return f"db3-junk-shm-{i}", side
    side["d.db3-wal"] = b""
    side["d.db3-shm"] = b"" if i % 2 else bytes(32768)
    return f"db3-empty-wal-shm-{i}", side


def sqlite_cases(rng: random.Random, n: int) -> Iterator[fc.Case]:
    """extract, info and cat on ROS 2 sqlite3 bags damaged every way."""
    db3 = _ros2_db3()
    for i in range(n):
        name, files = sqlite_damage(rng, i, db3)
        command = (["extract", "d.db3", "--out", fc.OUT], ["info", "d.db3"], ["cat", "d.db3"])[
            i // 7 % 3
        ]
        yield _files_case("sqlite", f"{command[0]}-{name}", files, command, frozenset({0, 1, 3}))


# -- binary junk in text logs ------------------------------------------------------------------


def _nul_for_newline(data: bytes, at: int) -> bytes:
    i = data.find(b"\n", at)
    return data if i < 0 else data[:i] + b"\x00" + data[i + 1 :]


def _nul_run(data: bytes, at: int) -> bytes:
    i = data.find(b"\n", at)
    return data if i < 1 else data[: i - 1] + b"\x00" * 4 + data[i + 3 :]


def _junk(data: bytes, at: int) -> bytes:
    return data[:at] + JUNK + data[at:]


DAMAGE = (_nul_for_newline, _nul_run, _junk)


def _asc_text() -> bytes:
    import can

    path = _base() / "clean.asc"
    if not path.exists():
        writer = can.ASCWriter(str(path))
        for t, ident, data in fc.real_can(300):
            writer.on_message_received(can.Message(timestamp=t, arbitration_id=ident, data=data))
        writer.stop()
    return path.read_bytes()


def _csv_text() -> bytes:
    rows = ["t_s,speed_mps", *(f"{i * 0.01:.6f},{10 + (i % 50) * 0.1:.4f}" for i in range(400))]
    return ("\n".join(rows) + "\n").encode()


def _gpx_text() -> bytes:
    import datetime

    import gpxpy.gpx

    gpx = gpxpy.gpx.GPX()
    track = gpxpy.gpx.GPXTrack()
    segment = gpxpy.gpx.GPXTrackSegment()
    gpx.tracks.append(track)
    track.segments.append(segment)
    t0 = datetime.datetime(2024, 1, 1, tzinfo=datetime.UTC)
    for i in range(120):
        when = t0 + datetime.timedelta(seconds=i)
        segment.points.append(gpxpy.gpx.GPXTrackPoint(48.0 + i * 1e-5, 11.0, time=when))
    return gpx.to_xml().encode()


def _count_at_least(want: int) -> Callable[[Path], str | None]:
    """A check that ``out/x.mcap`` holds at least ``want`` messages."""

    def need(out: Path) -> str | None:
        from superlane_tools.recording import open_recording

        path = out / "x.mcap"
        if not path.exists():
            return "no output"
        with open_recording(path) as rec:
            got = sum(1 for _ in rec.raw_messages())
        return None if got >= want else f"messages {got} < {want}"

    return need


def text_junk_cases(rng: random.Random, n: int) -> Iterator[fc.Case]:
    """``slt convert`` of NMEA, candump, ASC, CSV and GPX logs with binary junk in them."""
    logs: list[tuple[str, bytes, Callable[[bytes], bool] | None]] = [
        ("fixes.nmea", fc.nmea_text(), lambda line: b"GGA," in line),
        ("bus.log", fc.candump_text(), lambda line: line.startswith(b"(")),
        ("bus.asc", _asc_text(), None),
        ("speed.csv", _csv_text(), lambda line: line[:1].isdigit()),
        ("track.gpx", _gpx_text(), None),
    ]
    for i in range(n):
        fname, clean, is_record = logs[i % len(logs)]
        damage = DAMAGE[i // len(logs) % len(DAMAGE)]
        at = rng.randrange(1, len(clean) - 8)
        data = damage(clean, at)
        need = None
        if is_record is not None:  # a lower bound: records still whole lines of the damaged log
            whole = set(data.splitlines())
            intact = [ln for ln in clean.splitlines() if ln in whole and is_record(ln)]
            need = _count_at_least(len(intact))
        args = ["convert", fname, "-o", f"{fc.OUT}/x.mcap"]
        # a GPX is one XML document: junk in it may make the whole file unreadable (exit 1)
        expect = frozenset({0, 1, 3}) if fname.endswith(".gpx") else frozenset({0, 3})
        name = f"junk-{fname}-{damage.__name__.strip('_')}-{at}"
        yield _files_case("text_junk", name, {fname: data}, args, expect, need)


# -- topics of the wrong kind ------------------------------------------------------------------

TOPICS = {"/cam/compressed": "frames", "/can": "can", "/fix": "gnss"}
KINDS = ("frames", "can", "gnss", "camera_info")


def wrong_topic_cases(rng: random.Random, n: int) -> Iterator[fc.Case]:
    """extract and reprocess configs, camera estimate --topic: a topic of another kind."""
    drive = _mcap()
    variants: list[tuple[str, Callable[[Path, str, str], list[str]], frozenset[int]]] = []

    def extract_yaml(work: Path, kind: str, topic: str) -> list[str]:
        (work / "c.yaml").write_text(f"{kind}: [{topic}]\n")
        return ["extract", "d.mcap", "--config", "c.yaml", "--out", fc.OUT]

    def extract_streams(work: Path, kind: str, topic: str) -> list[str]:
        (work / "c.yaml").write_text(f"streams:\n  {kind}: [{topic}]\n")
        return ["extract", "d.mcap", "--config", "c.yaml", "--out", fc.OUT]

    def reprocess_toml(work: Path, kind: str, topic: str) -> list[str]:
        (work / "r.toml").write_text(f'[topics]\n{kind} = "{topic}"\n')
        return ["reprocess", "d.mcap", "--config", "r.toml", "--out", fc.OUT]

    def estimate(work: Path, kind: str, topic: str) -> list[str]:
        return ["camera", "estimate", "d.mcap", "--topic", topic]

    variants = [
        ("extract", extract_yaml, frozenset({2})),
        ("extract-streams", extract_streams, frozenset({2})),
        ("reprocess", reprocess_toml, frozenset({2})),
        ("estimate", estimate, frozenset({2})),
    ]
    combos = [
        (label, make, expect, kind, topic)
        for label, make, expect in variants
        for kind in (("frames",) if label == "estimate" else KINDS)
        for topic, topic_kind in TOPICS.items()
        if topic_kind != kind
    ]
    for i in range(n):
        label, make, expect, kind, topic = combos[i % len(combos)]

        def build(
            work: Path, make: Callable[..., list[str]] = make, kind: str = kind, topic: str = topic
        ) -> list[str]:
            (work / "d.mcap").write_bytes(drive)
            return make(work, kind, topic)

        yield fc.Case("wrong_topic", f"{label}-{kind}-{topic}-{i}", build, expect, None)


# -- malformed batch manifests -----------------------------------------------------------------

MANIFESTS: list[tuple[str, str, str]] = [  # (name, file name, text with {p} for the path)
    ("path-list", "m.yaml", "- path: [{p}]\n"),
    ("path-mapping", "m.yaml", "- path: {{a: {p}}}\n"),
    ("path-bool", "m.yaml", "- path: true\n"),
    ("path-int", "m.yaml", "- path: 12\n"),
    ("path-null", "m.yaml", "- path: null\n"),
    ("no-path-key", "m.yaml", "- category: highway\n"),
    ("row-is-list", "m.yaml", "- [{p}, highway]\n"),
    ("row-is-text", "m.yaml", "- {p}\n"),
    ("top-mapping", "m.yaml", "path: {p}\n"),
    ("top-scalar", "m.yaml", "42\n"),
    ("empty-yaml", "m.yaml", ""),
    ("category-list", "m.yaml", "- path: {p}\n  category: [a, b]\n"),
    ("vehicle-mapping", "m.yaml", "- path: {p}\n  vehicle: {{x: 1}}\n"),
    ("sequence-bool", "m.yaml", "- path: {p}\n  sequence: true\n"),
    ("start-text", "m.yaml", "- path: {p}\n  start_s: abc\n"),
    ("start-bool", "m.yaml", "- path: {p}\n  start_s: false\n"),
    ("window-reversed", "m.yaml", "- path: {p}\n  start_s: 5\n  end_s: 1\n"),
    ("window-negative", "m.yaml", "- path: {p}\n  start_s: -3\n"),
    ("window-nan", "m.yaml", "- path: {p}\n  end_s: .nan\n"),
    ("window-inf", "m.yaml", "- path: {p}\n  start_s: .inf\n"),
    ("missing-path", "m.yaml", "- path: nosuch.mcap\n"),
    ("missing-path-csv", "m.csv", "path\nnosuch.mcap\n"),
    ("csv-no-path-column", "m.csv", "file,category\n{p},x\n"),
    ("csv-empty-path", "m.csv", "path,category\n,x\n"),
    ("csv-window-text", "m.csv", "path,start_s,end_s\n{p},x,y\n"),
    ("csv-window-reversed", "m.csv", "path,start_s,end_s\n{p},9,2\n"),
    ("csv-binary", "m.csv", "path\n\x00\x01\x02\n"),
    ("csv-header-only", "m.csv", "path,category\n"),
    ("csv-ragged", "m.csv", "path,category\n{p},a,b,c\n"),
    ("duplicate-rows", "m.yaml", "- path: {p}\n- path: {p}\n"),
]


MANIFEST_EXITS = {
    "row-is-text": 0,  # a bare path is a row
    "duplicate-rows": 0,  # run once
    "missing-path": 1,
    "missing-path-csv": 1,
}
"""Exit codes of the manifests that are not usage errors."""


def manifest_cases(rng: random.Random, n: int) -> Iterator[fc.Case]:
    """``slt batch --manifest`` with cells of the wrong type, missing paths, bad windows."""
    drive = _mcap()
    for i in range(n):
        label, fname, text = MANIFESTS[i % len(MANIFESTS)]

        def build(work: Path, fname: str = fname, text: str = text) -> list[str]:
            (work / "d.mcap").write_bytes(drive)
            (work / "c.toml").write_text('frame_format = "none"\n')
            (work / fname).write_text(text.format(p="d.mcap"))
            return [
                "batch",
                "--manifest",
                fname,
                "--job",
                "extract",
                "--config",
                "c.toml",
                "--workers",
                "1",
                "--retries",
                "0",
                "--out",
                fc.OUT,
            ]

        # a bad cell, row or window is a usage error (2); a missing recording fails its row (1)
        expect = frozenset({MANIFEST_EXITS.get(label, 2)})
        yield fc.Case("manifest", f"manifest-{label}-{i}", build, expect, None)


# -- slt recover on every damaged kind ---------------------------------------------------------


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    from superlane_tools.recording import open_recording

    with open_recording(path) as rec:
        return sorted((m.topic, m.log_time_ns, bytes(m.payload)) for m in rec.raw_messages())


def _same_as_cat(src: str, out: str) -> Callable[[Path], str | None]:
    """A check that the recovered ``out`` reads back as what the damaged input reads."""

    def need(out_dir: Path) -> str | None:
        work = out_dir.parent
        try:
            want = _messages(work / src)
        except Exception:  # cat cannot open the damaged input: it reads nothing
            want = []
        got = _messages(out_dir / out)
        if got == want:
            return None
        return f"recovered {len(got)} messages, cat reads {len(want)} (or they differ)"

    return need


def recover_cases(rng: random.Random, n: int) -> Iterator[fc.Case]:
    """``slt recover`` on cut and garbled MCAP, ROS 1 and ROS 2 sqlite3 recordings."""
    mcap, bag, db3 = _mcap(), _ros1(), _ros2_db3()
    for i in range(n):
        kind = i % 6
        if kind == 0:
            pos = rng.randrange(8, len(mcap))
            name, files, out = f"mcap-cut-{pos}", {"d.mcap": mcap[:pos]}, "r.mcap"
        elif kind == 1:
            pos = rng.randrange(8, len(mcap))
            name, files, out = (
                f"mcap-garble-{pos}",
                {"d.mcap": fc._garble(mcap, pos, rng)},
                "r.mcap",
            )
        elif kind == 2:
            pos = rng.randrange(13, len(bag))
            name, files, out = f"ros1-cut-{pos}", {"d.bag": bag[:pos]}, "r.bag"
        elif kind == 3:
            pos = rng.randrange(13, len(bag))
            name, files, out = f"ros1-garble-{pos}", {"d.bag": fc._garble(bag, pos, rng)}, "r.bag"
        else:
            name, files = sqlite_damage(rng, i, db3)
            out = "r"
        src = next(iter(files))
        args = ["recover", src, "-o", f"{fc.OUT}/{out}"]
        yield _files_case(
            "recover", f"recover-{name}", files, args, frozenset({0, 1, 3}), _same_as_cat(src, out)
        )


FAMILIES2: dict[str, Callable[[random.Random, int], Iterator[fc.Case]]] = {
    "sqlite": sqlite_cases,
    "text_junk": text_junk_cases,
    "wrong_topic": wrong_topic_cases,
    "manifest": manifest_cases,
    "recover": recover_cases,
}
fc.FAMILIES.update(FAMILIES2)
