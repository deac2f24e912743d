"""The rule that makes a segmentation model the default: no worse anywhere, and fast enough.

A model becomes the default only when, in one run of the evaluation chain, it is no worse than
the best shipped model on **each** set its card's ``release`` section names (every real set, the
simulated held-out set, simulated held-out drives and the demo drive), beyond the measured
run-to-run noise (:data:`NOISE`), and its network costs at most :data:`SPEED_BUDGET` times the
speed reference's (:data:`SPEED_REFERENCE`) milliseconds measured in the same run. Until a
newer model passes, the incumbent stays the default. Sets whose name ends in ``_rmse`` are
lower-is-better; every other set is higher-is-better. A set a candidate's card lacks counts as
worse (nothing shows it is not).

Card layout (``metrics.release``)::

    release:
      sets: {tusimple_dev_laneeval: 0.847, demo_super_availability: 0.988, ...}
      ms_per_frame_same_run: {model: 15.0, reference: 15.0}
      command: how the numbers were measured
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

RELEASE = "release"
"""Card metrics section with the numbers the rule compares."""
SPEED_BUDGET = 1.2
"""The default's network may cost at most this many times the reference's, same run."""
SPEED_REFERENCE = "super_seg_v4"
"""The model whose milliseconds set the speed budget."""
INCUMBENT = "super_seg_v4"
"""The default before the rule existed: it stays until a newer model passes."""
NOISE = {"share": 0.005, "rmse_relative": 0.02}
"""Run-to-run noise: absolute on shares and scores (the chains are deterministic: repeated
runs gave the same numbers; 0.005 covers the cards' 4-digit rounding), relative on RMSEs."""


@dataclass(frozen=True)
class Verdict:
    """Whether a model passes the rule, and every set where it does not."""

    model: str
    passes: bool
    failures: tuple[str, ...]

    def line(self) -> str:
        """Return one line: passes, or the failures."""
        if self.passes:
            return f"{self.model}: passes the default rule"
        return f"{self.model}: not the default: " + "; ".join(self.failures)


def _worse(name: str, value: float, best: float) -> bool:
    if name.endswith("_rmse"):
        return value > best * (1.0 + NOISE["rmse_relative"])
    return value < best - NOISE["share"]


def judge(model: str, releases: Mapping[str, Mapping[str, Any]]) -> Verdict:
    """Judge ``model`` against every other model's ``release`` numbers.

    Args:
        model: The candidate (a key of ``releases``).
        releases: Model name -> its card's ``release`` section, for every shipped model that
            has one.
    """
    own = releases.get(model) or {}
    sets = dict(own.get("sets") or {})
    failures = []
    names = sorted({n for r in releases.values() for n in (r.get("sets") or {})})
    for name in names:
        others = {
            m: float(r["sets"][name])
            for m, r in releases.items()
            if m != model and name in (r.get("sets") or {})
        }
        if name not in sets:
            failures.append(f"{name}: not measured")
            continue
        if not others:
            continue
        pick = min if name.endswith("_rmse") else max
        best_model = pick(others, key=lambda m: others[m])
        if _worse(name, float(sets[name]), others[best_model]):
            value, best = float(sets[name]), others[best_model]
            failures.append(f"{name} {value:.4g} worse than {best_model}'s {best:.4g}")
    ms = own.get("ms_per_frame_same_run") or {}
    if "model" not in ms or "reference" not in ms:
        failures.append("speed: not measured beside the reference")
    elif float(ms["model"]) > SPEED_BUDGET * float(ms["reference"]):
        ratio = float(ms["model"]) / float(ms["reference"])
        failures.append(f"speed {ratio:.2f}x {SPEED_REFERENCE} (budget {SPEED_BUDGET}x)")
    return Verdict(model, not failures, tuple(failures))


def model_version(name: str) -> int:
    """Return the N of a ``..._vN`` model name (-1 without one)."""
    found = re.search(r"_v(\d+)$", name)
    return int(found.group(1)) if found else -1


def choose_default(releases: Mapping[str, Mapping[str, Any]], incumbent: str = INCUMBENT) -> str:
    """Return the newest model newer than ``incumbent`` that passes the rule, else ``incumbent``."""
    newer = sorted(
        (m for m in releases if model_version(m) > model_version(incumbent)), key=model_version
    )
    for model in reversed(newer):
        if judge(model, releases).passes:
            return model
    return incumbent


def shipped_releases() -> dict[str, dict[str, Any]]:
    """Return each shipped segmentation model's ``release`` section (those that have one)."""
    from superlane_tools.models import list_models
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import resolve_model

    releases = {}
    for name in list_models():
        card = load_card(resolve_model(name)[1])
        release = card.metrics.get(RELEASE)
        if card.task == "segmentation" and isinstance(release, dict):
            releases[name] = dict(release)
    return releases
