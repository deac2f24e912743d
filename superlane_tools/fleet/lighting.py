"""Night and low-contrast frames: image statistics and the ``low_light`` mining score (pure).

Statistics of a grayscale frame scaled to 0-1: the mean luminance and the RMS contrast (the
standard deviation of the intensities, Peli 1990). The score is the larger of

* darkness ``1 - mean / (2 * DARK_MEAN)``: 0.5 at a mean of :data:`DARK_MEAN`, 1 when black;
* flatness ``1 - contrast / (2 * FLAT_CONTRAST)``: 0.5 at :data:`FLAT_CONTRAST`, 1 when uniform;

clipped to 0-1, so a frame fires (>= 0.5) when it is darker than :data:`DARK_MEAN` or flatter
than :data:`FLAT_CONTRAST`. The thresholds come from real frames (grayscale at 1/4 size):
the 129 TuSimple day frames have a mean of 0.27-0.44 and a contrast of 0.17-0.31; the 10 CULane
night frames (``nightblur_0531_2336_0004``) a mean of 0.045-0.154 and a contrast of 0.09-0.145.
``DARK_MEAN = 0.2`` lies between the brightest night frame and the darkest day one (night
scores >= 0.61, day <= 0.33). Night frames keep some contrast (headlights, lit markings), so
darkness, not contrast, finds them; ``FLAT_CONTRAST = 0.08``, under half the flattest day
frame's, finds fog, glare and washed-out frames, where markings fade into the road.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import pandas as pd
from numpy.typing import NDArray

DARK_MEAN = 0.2
"""Mean luminance (0-1) under which a frame counts as night-dark."""
FLAT_CONTRAST = 0.08
"""RMS contrast (0-1) under which a frame counts as low contrast."""


def luminance_stats(gray: NDArray[np.generic]) -> tuple[float, float]:
    """Return ``(mean luminance, RMS contrast)`` of a grayscale image, both on 0-1.

    ``gray``: 2-D, uint8 (0-255) or float already on 0-1.

    Raises:
        ValueError: If the image is not 2-D or is empty.
    """
    if gray.ndim != 2 or gray.size == 0:
        raise ValueError(f"need a non-empty 2-D grayscale image, got shape {gray.shape}")
    values = gray.astype(np.float64)
    if gray.dtype == np.uint8:
        values /= 255.0
    return float(values.mean()), float(values.std())


def low_light_score(mean: float, contrast: float) -> float:
    """Return the ``low_light`` score 0-1 of a frame's statistics (see the module docstring)."""
    dark = 1.0 - mean / (2 * DARK_MEAN)
    flat = 1.0 - contrast / (2 * FLAT_CONTRAST)
    return float(np.clip(max(dark, flat), 0.0, 1.0))


def lighting_table(frames: Iterable[tuple[int, NDArray[np.generic]]]) -> pd.DataFrame:
    """Return ``log_time_ns``, ``mean_luminance``, ``rms_contrast``, ``low_light`` per frame.

    ``frames``: ``(log_time_ns, grayscale image)`` pairs.
    """
    rows = []
    for t_ns, gray in frames:
        mean, contrast = luminance_stats(gray)
        rows.append((int(t_ns), mean, contrast, low_light_score(mean, contrast)))
    return pd.DataFrame(
        rows, columns=["log_time_ns", "mean_luminance", "rms_contrast", "low_light"]
    ).astype({"log_time_ns": np.int64})
