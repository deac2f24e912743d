"""The drift rules of ``slt history`` on nightly series with known declines (fleet/drift.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from superlane_tools.fleet.drift import (
    CUSUM_SLACK,
    cusum_alarms,
    decline_alarms,
    drift_margin,
    drifts,
    worse_steps,
)

KPI = "availability_frames.super"  # higher is better, default margin 0.02 (2 pp)


def _series(values: list[float], verdicts: list[str | None] | None = None) -> pd.DataFrame:
    nights = [f"2026-11-{k + 1:02d}" for k in range(len(values))]
    return pd.DataFrame(
        {
            "night": nights,
            "kpi": KPI,
            "value": values,
            "verdict": verdicts or [None] * len(values),
        }
    )


def test_a_slow_steady_decline_is_flagged_and_uncaught() -> None:
    values = [0.95 - 0.006 * k for k in range(6)]  # 0.6 pp a night: under every gate's 2 pp
    found = drifts(_series(values))
    decline = found[found["rule"] == "decline"]
    assert len(decline) == 1
    row = decline.iloc[0]
    assert (row["first_night"], row["last_night"], row["nights"]) == ("2026-11-01", "2026-11-06", 6)
    assert np.isclose(row["change"], -0.03)
    assert not row["caught"]
    # 0.6 pp a night exceeds the CUSUM's slack of 0.25 pp by 0.35 pp: 6 steps to reach 2 pp
    assert found[found["rule"] == "cusum"].empty
    assert list(drifts(_series([*values, values[-1] - 0.006]))["rule"]) == ["decline+cusum"]


def test_noise_without_a_trend_is_not_flagged() -> None:
    rng = np.random.default_rng(0)
    values = list(0.95 + rng.normal(0.0, 0.003, 60))  # 0.3 pp of night-to-night noise
    assert drifts(_series(values)).empty


def test_cusum_catches_a_noisy_decline_the_decline_rule_misses() -> None:
    # each two nights: -1.5 pp then +0.3 pp: never three worse nights in a row
    values = [0.95]
    for _ in range(4):
        values += [values[-1] - 0.015, values[-1] - 0.012]
    steps = worse_steps(values, higher_is_better=True)
    assert decline_alarms(steps, 0.02) == []
    alarms = cusum_alarms(steps, 0.02)
    assert alarms
    assert (alarms[0].start, alarms[0].stop) == (0, 5)  # S: 1.25, 0.7, 1.95, 1.4, 2.65 pp
    assert CUSUM_SLACK == 0.125


def test_a_drift_a_night_s_gate_saw_is_caught() -> None:
    values = [0.95 - 0.006 * k for k in range(6)]
    verdicts: list[str | None] = [None, "no significant difference", "worse", None, None, None]
    row = drifts(_series(values, verdicts)).iloc[0]
    assert row["caught"]
    assert row["caught_by"] == "2026-11-03"


def test_lower_is_better_kpis_drift_upwards() -> None:
    frame = _series([0.010, 0.012, 0.014, 0.016]).assign(kpi="lane_width_jitter")
    found = drifts(frame)  # +2 mm a night, 6 mm in all: the margin is 1 cm
    assert found.empty
    found = drifts(frame, {"lane_width_jitter": 0.005})
    assert list(found["rule"]) == ["decline"]


def test_margins_come_from_the_option_then_the_defaults_then_the_timing_rule() -> None:
    assert drift_margin(KPI, [0.9], {KPI: 0.05}) == 0.05
    assert drift_margin(KPI, [0.9], {}) == 0.02
    assert np.isclose(drift_margin("frames_per_s", [10.0, 20.0, 30.0], {}), 4.0)  # 20 % of 20
    assert drift_margin("not_a_kpi", [1.0], {}) == np.inf
