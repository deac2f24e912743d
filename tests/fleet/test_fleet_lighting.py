"""The ``low_light`` score: constructed images, and the real day and night frames it was set on."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from superlane_tools.fleet.lighting import (
    DARK_MEAN,
    FLAT_CONTRAST,
    lighting_table,
    low_light_score,
    luminance_stats,
)


def _stripes(low: int, high: int) -> np.ndarray:
    """A 90x160 image of alternating columns ``low`` / ``high`` (mean and contrast known)."""
    image = np.full((90, 160), low, np.uint8)
    image[:, ::2] = high
    return image


def test_statistics_of_constructed_images() -> None:
    mean, contrast = luminance_stats(_stripes(0, 255))
    assert mean == pytest.approx(0.5)
    assert contrast == pytest.approx(0.5)
    assert luminance_stats(np.full((4, 4), 0.25)) == (0.25, 0.0)
    with pytest.raises(ValueError, match="2-D"):
        luminance_stats(np.zeros((4, 4, 3), np.uint8))


def test_score_fires_for_dark_or_flat_frames_only() -> None:
    day = _stripes(40, 200)  # mean 0.47, contrast 0.31
    night = _stripes(5, 60)  # mean 0.13, contrast 0.11: dark with lights
    fog = _stripes(150, 180)  # mean 0.65, contrast 0.06: washed out
    black = np.zeros((90, 160), np.uint8)
    scores = {
        n: low_light_score(*luminance_stats(i))
        for n, i in (("day", day), ("night", night), ("fog", fog), ("black", black))
    }
    assert scores["day"] == 0.0
    assert 0.5 <= scores["night"] < 1.0
    assert 0.5 <= scores["fog"] < 1.0
    assert scores["black"] == 1.0
    assert low_light_score(DARK_MEAN, 0.3) == pytest.approx(0.5)  # the thresholds score 0.5
    assert low_light_score(0.5, FLAT_CONTRAST) == pytest.approx(0.5)
    table = lighting_table([(7, night), (9, day)])
    assert list(table["log_time_ns"]) == [7, 9]
    assert table["low_light"].tolist() == [scores["night"], 0.0]


def _real_scores(folder: Path) -> list[float]:
    import cv2

    paths = sorted(folder.glob("*.jpg"))
    assert paths, folder
    grays = [np.asarray(cv2.imread(str(p), cv2.IMREAD_REDUCED_GRAYSCALE_4)) for p in paths]
    return lighting_table(enumerate(grays))["low_light"].tolist()


def test_real_night_frames_fire_and_real_day_frames_do_not(realdata: Path) -> None:
    night = _real_scores(realdata / "culane" / "nightblur_0531_2336_0004")
    day = _real_scores(realdata / "tusimple" / "train_frames" / "images")
    assert len(night) == 10
    assert min(night) >= 0.5
    assert len(day) == 129
    assert max(day) < 0.5
