"""Report plots (matplotlib Agg, imported late): curvature profiles, availability, examples."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.reporting.atomic import atomic_path
from superlane_tools.reporting.layout import (
    AVAILABILITY_PLOT,
    CURVATURE_DISTANCE_PLOT,
    CURVATURE_TIME_PLOT,
    example_plot_name,
)
from superlane_tools.reporting.names import CURVATURE_NAMES, METHOD_NOT_RUN

if TYPE_CHECKING:
    import pandas as pd

FloatArray = NDArray[np.float64]
_SOURCES = tuple(
    (key, CURVATURE_NAMES[key], colour)
    for key, colour in (
        ("rtk", "k"),
        ("super", "tab:blue"),
        ("super_path", "tab:green"),
        ("mobileye", "tab:orange"),
        ("mobileye_path", "tab:red"),
        ("dynamics", "tab:purple"),
    )
)


class LineDrawing(NamedTuple):
    """A fitted lane drawn in an image: pixels, marking colour and style, ego flag."""

    uv: FloatArray
    colour: str
    style: str
    ego: bool


class ExampleFrame(NamedTuple):
    """What the SUPER Fig. 8 style example plot shows for one frame.

    Attributes:
        frame_index: Frame index.
        t_ns: Frame time, ns.
        image_bgr: The frame (processing size).
        labels: Leaf-id segmentation.
        bev_xy: Lane pixels on the flat ground, ``(N, 2)`` x forward, y left, metres.
        residual_m: Lateral offsets after removing the fitted heading and curvature, metres.
        offsets_m: Fitted lane offsets (histogram peaks), metres.
        lanes: Fitted lanes to draw.
        info: Curvature, lane count and fit reason for the title.
    """

    frame_index: int
    t_ns: int
    image_bgr: NDArray[np.uint8]
    labels: NDArray[np.uint8]
    bev_xy: FloatArray
    residual_m: FloatArray
    offsets_m: FloatArray
    lanes: list[LineDrawing]
    info: dict[str, Any]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: Path) -> Path:
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    _pyplot().close(fig)
    return path


def _zoom_window(curv: FloatArray, n: int, half: int) -> tuple[int, int]:
    finite = np.where(np.isfinite(curv), np.abs(curv), -1.0)
    centre = int(np.argmax(finite)) if finite.size else 0
    return max(0, centre - half), min(n, centre + half)


def curvature_plots(curv: pd.DataFrame, out_dir: Path) -> list[Path]:
    """Curvature of RTK, SUPER and Mobileye over time and distance, with a zoom on the peak.

    Without a truth (no RTK curvature anywhere) there is no zoom panel: it would zoom on the
    largest value of a curve that does not exist.

    Args:
        curv: ``curvature.parquet`` columns (``t_s``, ``s_m``, ``rtk_curvature``, ...).
        out_dir: Folder of the PNG files.
    """
    plt = _pyplot()
    paths = []
    n = len(curv)
    half = max(15, n // 10)
    truth = curv["rtk_curvature"].to_numpy(dtype=float)
    has_truth = bool(np.isfinite(truth).any())  # no truth: no zoom on its largest value
    lo, hi = _zoom_window(truth, n, half) if has_truth else (0, 0)
    for axis, label, name in (
        ("t_s", "time (s)", CURVATURE_TIME_PLOT),
        ("s_m", "distance along RTK track (m)", CURVATURE_DISTANCE_PLOT),
    ):
        x = curv[axis].to_numpy(dtype=float)
        if axis == "s_m" and not np.isfinite(x).any():
            continue
        if has_truth:
            fig, (ax, zoom) = plt.subplots(2, 1, figsize=(10, 6.5))
        else:
            fig, ax = plt.subplots(figsize=(10, 3.8))
            zoom = None
        for key, text, colour in _SOURCES:
            if f"{key}_curvature" not in curv.columns:
                continue
            y = curv[f"{key}_curvature"].to_numpy(dtype=float)
            if np.isfinite(y).any():
                ax.plot(x, y, color=colour, lw=1.2, label=text)
                if zoom is not None:
                    zoom.plot(x[lo:hi], y[lo:hi], color=colour, lw=1.4, label=text)
        ax.set_xlabel(label)
        ax.set_ylabel("curvature (1/m, left +)")
        # One legend above the axes: it never hides a curve, and placing it costs nothing
        # (loc="best" searched every curve's points; with tight_layout that was half the plot).
        fig.legend(*ax.get_legend_handles_labels(), loc="upper center", ncol=3, fontsize=8)
        ax.grid(alpha=0.3)
        if zoom is None:
            fig.subplots_adjust(left=0.095, right=0.98, bottom=0.14, top=0.82)
            paths.append(_save(fig, out_dir / name))
            continue
        if hi > lo:
            ax.axvspan(np.nanmin(x[lo:hi]), np.nanmax(x[lo:hi]), color="grey", alpha=0.15)
        zoom.set_title("zoom: largest RTK curvature", fontsize=9)
        zoom.set_xlabel(label)
        zoom.set_ylabel("curvature (1/m)")
        zoom.grid(alpha=0.3)
        fig.subplots_adjust(left=0.095, right=0.98, bottom=0.08, top=0.89, hspace=0.35)
        paths.append(_save(fig, out_dir / name))
    return paths


def availability_plot(frames: pd.DataFrame, out_dir: Path) -> Path | None:
    """Availability timeline per method that ran (green available, red not, grey unknown).

    A method that did not run on the drive (every frame's reason starts with
    :data:`~superlane_tools.reporting.names.METHOD_NOT_RUN`) is left out, not drawn red; with
    no method left there is no plot (None).
    """
    not_run = frames["reason"].astype(str).str.startswith(METHOD_NOT_RUN)
    ran = not_run.groupby(frames["method"], sort=False).all()
    methods = [m for m in dict.fromkeys(frames["method"]) if not ran[m]]
    if not methods:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(10, 1.0 + 0.6 * len(methods)))
    for row, method in enumerate(methods):
        sel = frames[frames["method"] == method]
        t = (sel["log_time_ns"].to_numpy() - frames["log_time_ns"].min()) / 1e9
        colour = np.where(sel["available"], "tab:green", np.where(sel["known"], "tab:red", "grey"))
        ax.scatter(t, np.full(len(t), row), c=colour, marker="|", s=200)
    ax.set_yticks(range(len(methods)), methods)
    ax.set_xlabel("time (s)")
    ax.set_title(
        "lateral-control availability (green: available, red: not, grey: unknown, no speed)"
    )
    ax.set_ylim(-0.7, len(methods) - 0.3)
    fig.tight_layout()
    return _save(fig, out_dir / AVAILABILITY_PLOT)


def example_plot(example: ExampleFrame, out_dir: Path) -> Path:
    """SUPER Fig. 8 style panel: segmentation, BEV points, offset histogram with peaks, lanes."""
    import cv2
    from matplotlib.patches import Patch

    from superlane_tools.hierarchy import NODES, colorize
    from superlane_tools.reporting.video import draw_overlay

    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5))
    seg = cv2.addWeighted(example.image_bgr, 0.5, colorize(example.labels), 0.5, 0)
    axes[0, 0].imshow(seg[:, :, ::-1])
    axes[0, 0].set_title("segmentation (leaf classes)")
    present = set(np.unique(example.labels).tolist())
    handles = [
        Patch(
            color=(n.color_bgr[2] / 255, n.color_bgr[1] / 255, n.color_bgr[0] / 255), label=n.name
        )
        for n in NODES
        if n.leaf_id >= 0 and n.leaf_id in present
    ]
    if handles:  # the class legend: which colour is which class
        axes[0, 0].legend(handles=handles, loc="upper right", fontsize=6, framealpha=0.8)
    bev = example.bev_xy
    axes[0, 1].scatter(bev[:, 1], bev[:, 0], s=1, c="k")
    axes[0, 1].set_xlim(12, -12)
    axes[0, 1].set_xlabel("y (m, left +)")
    axes[0, 1].set_ylabel("x forward (m)")
    axes[0, 1].set_title("lane pixels on the ground (BEV)")
    bins = np.arange(-12, 12.05, 0.1)
    axes[1, 0].hist(example.residual_m, bins=bins, color="tab:blue")
    for off in example.offsets_m:
        axes[1, 0].axvline(off, color="tab:red", lw=1)
    axes[1, 0].set_xlabel("offset after heading/curvature compensation (m)")
    axes[1, 0].set_title("offset histogram and peaks (red)")
    drawn = draw_overlay(example.image_bgr, example.lanes)
    axes[1, 1].imshow(drawn[:, :, ::-1])
    info = example.info
    axes[1, 1].set_title(
        f"fitted lanes: {info.get('lanes', 0)}, curvature {info.get('curvature', float('nan')):.2e}"
        " 1/m"
    )
    for ax in (axes[0, 0], axes[1, 1]):
        ax.axis("off")
    fig.suptitle(f"frame {example.frame_index}")
    fig.tight_layout()
    return _save(fig, out_dir / example_plot_name(example.frame_index))


def plot_all(
    curv: pd.DataFrame | None, frames: pd.DataFrame, examples: Sequence[ExampleFrame], out_dir: Path
) -> list[Path]:
    """Write every plot of a run into ``out_dir``; return the files."""
    paths = []
    if curv is not None and len(curv):
        paths += curvature_plots(curv, out_dir)
    if len(frames) and (timeline := availability_plot(frames, out_dir)) is not None:
        paths.append(timeline)
    paths += [example_plot(ex, out_dir) for ex in examples]
    return paths
