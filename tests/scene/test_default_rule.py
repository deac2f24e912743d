"""The default segmentation model is the one the rule picks: no worse anywhere, fast enough."""

from __future__ import annotations

from typing import Any

from superlane_tools.scene.backends import auto_candidates
from superlane_tools.scene.default_rule import (
    NOISE,
    SPEED_BUDGET,
    choose_default,
    judge,
    shipped_releases,
)
from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL


def _release(ms: float = 15.0, **sets: float) -> dict[str, Any]:
    return {"sets": sets, "ms_per_frame_same_run": {"model": ms, "reference": 15.0}}


BASE = _release(real_f1=0.50, demo_availability=0.988, demo_super_path_rmse=6.3e-4)


def test_better_everywhere_and_fast_enough_becomes_the_default() -> None:
    new = _release(16.0, real_f1=0.60, demo_availability=0.990, demo_super_path_rmse=6.0e-4)
    releases = {"super_seg_v4": BASE, "super_seg_v6": new}
    assert judge("super_seg_v6", releases).passes
    assert choose_default(releases) == "super_seg_v6"


def test_worse_on_one_set_is_not_the_default_whatever_it_wins_elsewhere() -> None:
    """super_seg_v5's case: far better on real frames, far worse on the demo drive."""
    new = _release(16.0, real_f1=0.90, demo_availability=0.362, demo_super_path_rmse=6.0e-4)
    releases = {"super_seg_v4": BASE, "super_seg_v5": new}
    verdict = judge("super_seg_v5", releases)
    assert not verdict.passes
    assert verdict.failures == ("demo_availability 0.362 worse than super_seg_v4's 0.988",)
    assert choose_default(releases) == "super_seg_v4"


def test_noise_slow_networks_missing_sets_and_lower_is_better_rmse() -> None:
    within = _release(
        15.0,
        real_f1=0.50 - NOISE["share"] / 2,
        demo_availability=0.988,
        demo_super_path_rmse=6.3e-4 * (1 + NOISE["rmse_relative"] / 2),
    )
    assert judge("m_v6", {"super_seg_v4": BASE, "m_v6": within}).passes
    slow = _release(15.0 * SPEED_BUDGET + 0.1, real_f1=0.6, demo_availability=0.99,
                    demo_super_path_rmse=6e-4)  # fmt: skip
    assert "speed" in judge("m_v6", {"super_seg_v4": BASE, "m_v6": slow}).failures[0]
    missing = _release(15.0, real_f1=0.6, demo_availability=0.99)
    assert judge("m_v6", {"super_seg_v4": BASE, "m_v6": missing}).failures == (
        "demo_super_path_rmse: not measured",
    )
    rougher = _release(15.0, real_f1=0.6, demo_availability=0.99, demo_super_path_rmse=7e-4)
    assert "demo_super_path_rmse" in judge("m_v6", {"super_seg_v4": BASE, "m_v6": rougher}).line()


def test_the_shipped_default_is_the_rules_pick() -> None:
    releases = shipped_releases()
    assert {"super_seg_v4", "super_seg_v5"} <= set(releases)
    for release in releases.values():  # every card carries every set the rule compares
        assert {"demo_super_availability", "demo_super_path_rmse"} <= set(release["sets"])
        assert any(name.startswith("culane_day") for name in release["sets"])
    assert choose_default(releases) == DEFAULT_SEGMENTATION_MODEL == "super_seg_v4"
    assert not judge("super_seg_v5", releases).passes
    newest = judge("super_seg_v8", releases)  # 100 % on the demo drive, not better everywhere
    assert not newest.passes
    assert "kitti_um_000000_f" in newest.line()


def test_auto_tries_every_candidate_that_could_win_fastest_first() -> None:
    assert auto_candidates() == (
        ("onnx", "super_seg_v4"),
        ("onnx", "super_seg_v8"),  # the newest model, not the default: it may win a drive
        ("classical", ""),
    )


def test_the_release_chain_measures_every_set_the_shipped_cards_compare() -> None:
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parents[2] / "pipelines" / "release_eval.py"
    spec = importlib.util.spec_from_file_location("release_eval", path)
    assert spec is not None
    assert spec.loader is not None
    release_eval = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(release_eval)
    for name, release in shipped_releases().items():
        assert set(release["sets"]) == set(release_eval.SETS), name
