"""The paths inside each kind of output folder: a table by its spec's name, other files by name.

A layout's tables are not listed here: every :class:`~.tables.TableSpec` of the layout's
stages is an attribute of the layout by its name (``RunLayout(root).lanes``), resolved from
:data:`~.tables.TABLES`. Files that are not tables are :class:`_File` attributes.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar, overload

from superlane_tools.reporting.layout.names import (
    ANNOTATIONS_FILE,
    COMPARE_DELTAS_PLOT,
    COMPARE_REPORT_FILE,
    HISTORY_DIR,
    HISTORY_PARTITION,
    HISTORY_REPORT_FILE,
    MANIFEST_FILE,
    MINE_IMAGES_DIR,
    NIGHTLY_COMPARE_DIR,
    NIGHTLY_MINED_DIR,
    OVERLAY_FILE,
    PLOTS_DIR,
    REPORT_FILE,
    REPORT_HTML_FILE,
    TUSIMPLE_LABELS_FILE,
)
from superlane_tools.reporting.layout.tables import Stage, TableSpec, tables_of


class _File:
    """A path inside a layout's root, by file name (a read-only attribute of the layout)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.__doc__ = f"``ROOT/{name}``."

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> _File: ...
    @overload
    def __get__(self, obj: _Layout, owner: type | None = None) -> Path: ...
    def __get__(self, obj: _Layout | None, owner: type | None = None) -> Path | _File:
        return self if obj is None else obj.root / self.name


@dataclass(frozen=True)
class _Layout:
    """An output folder; its tables (those of :attr:`STAGES`) are attributes by name."""

    root: Path
    STAGES: ClassVar[tuple[Stage, ...]] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "root", Path(self.root))

    @classmethod
    def tables(cls) -> dict[str, TableSpec]:
        """Return name -> spec of the tables of this kind of folder."""
        return {name: t for stage in cls.STAGES for name, t in tables_of(stage).items()}

    def __getattr__(self, name: str) -> Path:
        spec = None if name.startswith("_") else self.tables().get(name)
        if spec is None:
            raise AttributeError(f"{type(self).__name__} has no table or file {name!r}")
        return Path(self.__dict__["root"]) / spec.file

    def table(self, name: str) -> Path:
        """Return the path of a table by name.

        Raises:
            KeyError: For a name that is not a table of this kind of folder.
        """
        spec = self.tables().get(name)
        if spec is None:
            raise KeyError(f"not a table of {type(self).__name__}: {name!r}")
        return self.root / spec.file


@dataclass(frozen=True)
class RunLayout(_Layout):
    """The paths of one reprocess run folder: its tables (``streamed``, ``derived``) and files.

    Args:
        root: The run folder (``slt reprocess --out``).
    """

    STAGES: ClassVar[tuple[Stage, ...]] = ("streamed", "derived")
    annotations = _File(ANNOTATIONS_FILE)
    overlay = _File(OVERLAY_FILE)
    report = _File(REPORT_FILE)
    report_html = _File(REPORT_HTML_FILE)
    plots = _File(PLOTS_DIR)
    manifest = _File(MANIFEST_FILE)

    def streamed(self) -> dict[str, Path]:
        """Return table -> path of the tables written while the frames stream."""
        return {name: self.root / t.file for name, t in tables_of("streamed").items()}

    def derived(self) -> dict[str, Path]:
        """Return table -> path of the tables derived after the pass."""
        return {name: self.root / t.file for name, t in tables_of("derived").items()}


@dataclass(frozen=True)
class ExtractLayout(_Layout):
    """The paths of one ``slt extract`` output folder (images go under ``frames/<topic>/``)."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("extract",)


@dataclass(frozen=True)
class SummaryLayout(_Layout):
    """The paths of ``slt batch``'s fleet summary folder (``ROOT/summary``)."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("summary",)
    report = _File(REPORT_FILE)
    comparison = _File(NIGHTLY_COMPARE_DIR)
    mined = _File(NIGHTLY_MINED_DIR)


@dataclass(frozen=True)
class BatchLayout(_Layout):
    """The paths of ``slt batch``'s output root (its status table; one run folder a recording)."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("batch",)


@dataclass(frozen=True)
class CompareLayout(_Layout):
    """One ``slt compare`` output folder: tables ``compare``, ``spans``, ``drives``; the report."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("compare",)
    report = _File(COMPARE_REPORT_FILE)
    plots = _File(PLOTS_DIR)

    def deltas_plot(self) -> Path:
        """Return the path of the per-drive delta plot."""
        return self.plots / COMPARE_DELTAS_PLOT

    def timeline_plot(self, k: int) -> Path:
        """Return the path of the ``k``-th worst drive's availability timelines."""
        return self.plots / f"timeline_{k}.png"


@dataclass(frozen=True)
class MineLayout(_Layout):
    """The paths of one ``slt mine`` label set (table ``manifest``)."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("mine",)
    labels = _File(TUSIMPLE_LABELS_FILE)
    images = _File(MINE_IMAGES_DIR)


@dataclass(frozen=True)
class DatasetLayout(_Layout):
    """The paths of one training-set folder (``slt simulate dataset``; table ``index``)."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("dataset",)


@dataclass(frozen=True)
class HistoryLayout(_Layout):
    """The fleet's history under a nightly root: the dataset and one night's partition."""

    dataset = _File(HISTORY_DIR)

    def partition(self, night: str) -> Path:
        """Return the folder of one night's files (``history/night=DATE``)."""
        return self.dataset / f"{HISTORY_PARTITION}={night}"


@dataclass(frozen=True)
class HistoryReportLayout(_Layout):
    """The paths of one ``slt history`` output folder (table ``drifts``)."""

    STAGES: ClassVar[tuple[Stage, ...]] = ("history",)
    report = _File(HISTORY_REPORT_FILE)
    plots = _File(PLOTS_DIR)

    def kpi_plot(self, kpi: str) -> Path:
        """Return the path of one KPI's plot over the nights."""
        return self.plots / f"history_{kpi.replace('.', '_')}.png"


def is_reprocess_run(folder: str | os.PathLike[str]) -> bool:
    """Return whether ``folder`` is a complete reprocess run (by its files; sizes unchecked).

    A complete run holds :data:`MANIFEST_FILE` (written last), the availability tables and the
    report; drives without a camera have no streamed tables, so those are not required. Use
    :func:`~superlane_tools.reporting.run_folder.require_complete_run` to also check sizes.
    """
    layout = RunLayout(Path(folder))
    needed = (layout.manifest, layout.availability_sequences, layout.report)
    return layout.root.is_dir() and all(p.is_file() for p in needed)
