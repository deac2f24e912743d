"""Batch inputs: find recordings under folders, read manifests, name recordings."""

from __future__ import annotations

import datetime
import hashlib
import math
import numbers
import os
import re
import reprlib
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools.errors import ConfigError, UsageError

MANIFEST_COLUMNS = ("path", "category", "vehicle", "date", "sequence", "start_s", "end_s")
"""Manifest columns; only ``path`` is required."""


class BatchEntry(NamedTuple):
    """One recording (or one sequence of it) to process, with the labels that go in the tables.

    Attributes:
        path: Recording file or ROS 2 bag folder.
        category: Category for the fleet tables (e.g. ``highway``, ``heavy_rain``); ``""``: none.
        vehicle: Vehicle name; ``""``: unknown.
        date: Drive date as written in the manifest (``YYYY-MM-DD``); ``""``: unknown.
        sequence: Sequence name when a recording is split into sequences; ``""``: whole.
        start_s: Sequence start, seconds after the recording's first message; None: start.
        end_s: Sequence end (exclusive), seconds after the first message; None: end.
    """

    path: Path
    category: str = ""
    vehicle: str = ""
    date: str = ""
    sequence: str = ""
    start_s: float | None = None
    end_s: float | None = None


def find_recordings(folder: Path) -> Iterator[Path]:
    """Yield recordings under ``folder`` recursively, sorted: files and ROS 2 bag folders.

    What is a recording the reader plug-ins say (``recording.open.discovered``): MCAP files,
    ROS 1 bags, CAN logs, ROS 2 bag folders. Hidden entries (``.tmp``, ``.git``) are not
    searched; a recording folder is yielded whole and not searched further.
    """
    from superlane_tools.recording.open import discovered, is_recording_folder

    entries = sorted(folder.iterdir())
    for entry in entries:
        if entry.name.startswith("."):
            continue
        if entry.is_dir():
            if is_recording_folder(entry):
                yield entry
            else:
                yield from find_recordings(entry)
        elif entry.is_file() and discovered(entry):
            yield entry


def expand_inputs(inputs: Sequence[Path]) -> list[BatchEntry]:
    """Turn command-line inputs (recordings, ROS 2 bags, folders) into batch entries.

    Raises:
        UsageError: If an input does not exist or a folder holds no recordings.
    """
    from superlane_tools.recording.open import discovery_hint, is_recording_folder

    entries: list[BatchEntry] = []
    for item in inputs:
        path = Path(item)
        if not path.exists():
            raise UsageError(f"{path} does not exist")
        if path.is_dir() and not is_recording_folder(path):
            found = list(find_recordings(path))
            if not found:
                raise UsageError(f"{path}: no recordings found ({discovery_hint()})")
            entries.extend(BatchEntry(p) for p in found)
        else:
            entries.append(BatchEntry(path))
    return entries


_LABEL_TYPES = (str, numbers.Real, datetime.date)
"""Cell types a label column may hold (a YAML date or number is written as text)."""


def _kind(value: Any) -> str:
    """Name a manifest cell's type and value for an error message (``a list (['a.mcap'])``)."""
    if isinstance(value, Mapping):
        kind = "a mapping"
    elif isinstance(value, list | tuple | set | frozenset):
        kind = "a list"
    elif isinstance(value, bool):
        kind = "a boolean"
    else:
        name = type(value).__name__
        kind = f"{'an' if name[0] in 'aeiou' else 'a'} {name}"
    return f"{kind} ({reprlib.repr(value)})"


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def _text(value: Any, column: str, where: str) -> str:
    """Return a label cell as stripped text; ``""`` when empty.

    Raises:
        ConfigError: If the cell is not a scalar (a list, a mapping, a boolean...).
    """
    if _missing(value):
        return ""
    if isinstance(value, bool) or not isinstance(value, _LABEL_TYPES):
        raise ConfigError(f"{where}: {column} must be text, not {_kind(value)}")
    if isinstance(value, datetime.date):
        return value.isoformat()
    return str(value).strip()


def _path_text(value: Any, where: str) -> str:
    if _missing(value):
        return ""
    if not isinstance(value, str):
        raise ConfigError(f"{where}: path must be one recording path (text), not {_kind(value)}")
    if "\x00" in value:  # the OS refuses it: an internal ValueError otherwise
        raise ConfigError(f"{where}: path holds a NUL byte ({reprlib.repr(value)})")
    return value.strip()


def _seconds(value: Any, column: str, where: str) -> float | None:
    if isinstance(value, bool) or not (_missing(value) or isinstance(value, str | numbers.Real)):
        raise ConfigError(f"{where}: {column} must be a number of seconds, not {_kind(value)}")
    if isinstance(value, float) and math.isnan(value):  # YAML .nan (empty cells are None here)
        raise ConfigError(f"{where}: {column} must be a finite number >= 0 s, not nan")
    text = _text(value, column, where)
    if not text:
        return None
    try:
        seconds = float(text)
    except ValueError as err:
        raise ConfigError(f"{where}: {column} must be a number of seconds, not {text!r}") from err
    if not math.isfinite(seconds) or seconds < 0:
        raise ConfigError(f"{where}: {column} must be a finite number >= 0 s, not {text!r}")
    return seconds


def _rows(path: Path) -> list[Any]:
    suffix = path.suffix.lower()
    try:
        if suffix in {".yaml", ".yml"}:
            from superlane_tools.config_files import load_document

            raw = load_document(path, "manifest")
            if isinstance(raw, dict):
                raw = raw.get("recordings")
            if not isinstance(raw, list):
                raise ConfigError(
                    f"{path}: a YAML manifest is a list of {{path: ...}} mappings "
                    "(or a mapping with a 'recordings' list)"
                )
            return [{"path": r} if isinstance(r, str) else r for r in raw]
        import pandas as pd

        if suffix == ".parquet":
            frame = pd.read_parquet(path)
        elif suffix in {".csv", ".tsv"}:
            import warnings

            with warnings.catch_warnings():  # a row with more fields than the header: refused
                warnings.simplefilter("error", pd.errors.ParserWarning)
                sep = "\t" if suffix == ".tsv" else ","
                frame = pd.read_csv(path, sep=sep, dtype=str, index_col=False)
        else:
            raise ConfigError(f"{path}: manifest must be .csv, .tsv, .parquet, .yaml or .yml")
    except ConfigError:
        raise
    except Exception as err:  # pandas/pyarrow/yaml raise many types for unreadable files
        raise ConfigError(f"{path}: cannot read manifest: {err}") from err
    frame = frame.astype(object).where(frame.notna(), None)  # pd.NA, NaT, NaN: empty
    return [{str(k): v for k, v in r.items()} for r in frame.to_dict(orient="records")]


def read_manifest(path: str | os.PathLike[str]) -> list[BatchEntry]:
    """Read a manifest (CSV/TSV, Parquet or YAML) of recordings and their labels.

    Columns (keys in YAML): ``path`` (required; relative paths are relative to the manifest's
    folder), and optional ``category``, ``vehicle``, ``date``, ``sequence``, ``start_s``,
    ``end_s``. A recording may appear on several rows with different sequences.

    Raises:
        ConfigError: If the file is unreadable, lacks ``path``, or has bad values.
    """
    src = Path(path)
    if not src.is_file():
        raise UsageError(f"manifest {src} does not exist")
    rows = _rows(src)
    entries: list[BatchEntry] = []
    for number, row in enumerate(rows, start=1):
        where = f"{src}: row {number}"
        if not isinstance(row, Mapping):
            raise ConfigError(
                f"{where}: a row is a path or a {{path: ...}} mapping, not {_kind(row)}"
            )
        unknown = {str(key) for key in row} - set(MANIFEST_COLUMNS)
        if unknown:
            raise ConfigError(f"{where}: unknown columns {sorted(unknown)}; use {MANIFEST_COLUMNS}")
        text = _path_text(row.get("path"), where)
        if not text:
            raise ConfigError(f"{where}: missing path")
        rec = Path(text).expanduser()
        if not rec.is_absolute():
            rec = src.parent / rec
        start = _seconds(row.get("start_s"), "start_s", where)
        end = _seconds(row.get("end_s"), "end_s", where)
        if start is not None and end is not None and end <= start:
            raise ConfigError(f"{where}: end_s ({end}) must be after start_s ({start})")
        entries.append(
            BatchEntry(
                path=rec,
                category=_text(row.get("category"), "category", where),
                vehicle=_text(row.get("vehicle"), "vehicle", where),
                date=_text(row.get("date"), "date", where),
                sequence=_text(row.get("sequence"), "sequence", where),
                start_s=start,
                end_s=end,
            )
        )
    if not entries:
        raise ConfigError(f"{src}: the manifest lists no recordings")
    return entries


_UNSAFE = re.compile(r"[^A-Za-z0-9_-]+")


def recording_id(entry: BatchEntry, content_hash: str) -> str:
    """Return the output folder name of an entry: sanitised stem (+ sequence) + short hash.

    The hash part is the first 10 hex digits of the content hash (``algorithm:hex``, see
    ``reporting.InputIdentity``), mixed with the sequence window when there is one, so the same
    content always gets the same id wherever it lies.
    """
    digest = content_hash.rpartition(":")[2]
    stem = entry.path.name if entry.path.is_dir() else entry.path.stem
    name = _UNSAFE.sub("_", stem).strip("_")[:48] or "recording"
    if entry.sequence or entry.start_s is not None or entry.end_s is not None:
        seq = _UNSAFE.sub("_", entry.sequence).strip("_")[:24]
        name = f"{name}-{seq}" if seq else name
        window = f"{content_hash}|{entry.sequence}|{entry.start_s}|{entry.end_s}"
        return f"{name}-{hashlib.sha256(window.encode()).hexdigest()[:10]}"
    return f"{name}-{digest[:10]}"


def fingerprint(path: Path) -> tuple[int, int]:
    """Return ``(size_bytes, newest mtime_ns)`` of a file or folder, a cheap change check."""
    if path.is_dir():
        files: Iterable[Path] = (p for p in path.rglob("*") if p.is_file())
        stats = [p.stat() for p in files]
        return sum(s.st_size for s in stats), max((s.st_mtime_ns for s in stats), default=0)
    st = path.stat()
    return st.st_size, st.st_mtime_ns
