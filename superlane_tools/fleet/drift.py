"""Drift over the nights that no single night's gate caught (pure: a nightly series in, alarms out).

Each night's gate judges that night against its baseline; a KPI that loses a little every
night, or after each of several model releases, passes every gate and still ends far from
where it started. Two rules watch each KPI's nightly fleet value ``v`` (nights without a value
are skipped). With ``w_t`` the night's change in the worse direction (``v_{t-1} - v_t`` when
higher is better, ``v_t - v_{t-1}`` otherwise) and ``m`` the KPI's drift margin:

* **decline**: at least :data:`DECLINE_STEPS` consecutive worsening nights (``w_t > 0``, so
  ``DECLINE_STEPS + 1`` nights), whose summed change reaches ``m``. It catches a slow,
  steady decline whatever the step size.
* **cusum**: a one-sided CUSUM (Page 1954) on the nightly changes,
  ``S_t = max(0, S_{t-1} + w_t - m * CUSUM_SLACK)``, alarm when ``S_t >= m`` (then ``S`` restarts
  at 0). The changes telescope: ``S`` is the fall from the best value since ``S`` was last 0,
  less an eighth of the margin per night, so a steady worsening under ``m / 8`` a night is
  tolerated, a better night pays back a worse one, and it catches a decline with better nights
  in between, which the decline rule misses, and a single step past ``1.125 m``.

Alarms of one KPI whose windows overlap or touch are one drift (``rule`` = ``decline+cusum``).
An alarm is **caught** when a night inside its window (after its first night) had a comparison
verdict ``worse`` for that KPI: that night's gate saw it. The others are the drifts the gates
missed. Margins (:func:`drift_margin`): ``--margin KPI:VALUE``; else the KPI's own margin where
the KPI defines one; else :data:`DEFAULT_MARGINS`; for ``frames_per_s`` (a timing that varies
between identical runs) 20 % of the series' median.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from superlane_tools.fleet.kpis import KPI_BY_NAME
from superlane_tools.reporting.layout import HISTORY_DRIFTS_TABLE

DECLINE_STEPS = 3
"""Consecutive worsening nights (changes) the decline rule needs."""
CUSUM_SLACK = 0.125
"""Nightly worsening tolerated by the CUSUM, as a fraction of the margin."""
WORSE = "worse"
RULES = ("decline", "cusum")
DEFAULT_MARGINS: Mapping[str, float] = {
    "availability_frames": 0.02,
    "availability_sequences": 0.05,
    "ego_pair_share": 0.02,
    "curvature_rmse_truth": 1e-4,
    "curvature_rmse_dynamics": 1e-4,
    "lane_width_bias": 0.05,
    "lane_width_jitter": 0.01,
    "fit_cost": 0.1,
}
"""Drift margins by KPI family, in the KPI's unit (ratios 0-1: 0.02 is 2 pp)."""
COLUMNS = list(HISTORY_DRIFTS_TABLE.columns)
"""Columns of the drift table (``history_drifts.parquet``, declared by its spec)."""


@dataclass(frozen=True)
class Alarm:
    """One drift alarm: the rule and the window of nights ``[start, stop]`` (positions)."""

    rule: str
    start: int
    stop: int


def drift_margin(kpi: str, values: Sequence[float], given: Mapping[str, float]) -> float:
    """Return the drift margin of ``kpi`` (see the module docstring)."""
    if kpi in given:
        return float(given[kpi])
    spec = KPI_BY_NAME.get(kpi)
    own = getattr(spec, "margin", None)
    if own is not None and np.isfinite(own) and own > 0:
        return float(own)
    if spec is not None and spec.relative_margin > 0:
        finite = np.asarray([v for v in values if np.isfinite(v)])
        return spec.relative_margin * float(np.median(np.abs(finite))) if finite.size else np.inf
    family = kpi.partition(".")[0]
    return DEFAULT_MARGINS.get(family, np.inf)


def worse_steps(values: Sequence[float], higher_is_better: bool) -> np.ndarray:
    """Return each night's change in the worse direction (length ``len(values) - 1``)."""
    v = np.asarray(values, dtype=np.float64)
    steps = np.diff(v)
    return -steps if higher_is_better else steps


def decline_alarms(steps: np.ndarray, margin: float) -> list[Alarm]:
    """Return the runs of >= :data:`DECLINE_STEPS` worsening steps summing to ``margin``."""
    out = []
    k = 0
    while k < len(steps):
        if steps[k] <= 0:
            k += 1
            continue
        end = k
        while end + 1 < len(steps) and steps[end + 1] > 0:
            end += 1
        if end - k + 1 >= DECLINE_STEPS and steps[k : end + 1].sum() >= margin:
            out.append(Alarm("decline", k, end + 1))  # nights k .. end + 1
        k = end + 1
    return out


def cusum_alarms(steps: np.ndarray, margin: float) -> list[Alarm]:
    """Return the one-sided CUSUM alarms of the worsening steps (see the module docstring)."""
    out = []
    total, start = 0.0, 0
    for k, step in enumerate(steps):
        if total == 0.0:
            start = k
        total = max(0.0, total + float(step) - CUSUM_SLACK * margin)
        if total >= margin:
            out.append(Alarm("cusum", start, k + 1))
            total = 0.0
    return out


def merged(alarms: Sequence[Alarm]) -> list[Alarm]:
    """Join alarms whose windows overlap or touch into one (rules joined by ``+``)."""
    out: list[Alarm] = []
    for alarm in sorted(alarms, key=lambda a: (a.start, a.stop)):
        if out and alarm.start <= out[-1].stop:
            last = out[-1]
            rules = {*last.rule.split("+"), alarm.rule}
            rule = "+".join(r for r in RULES if r in rules)
            out[-1] = Alarm(rule, last.start, max(last.stop, alarm.stop))
        else:
            out.append(alarm)
    return out


def kpi_drifts(
    kpi: str,
    nights: Sequence[str],
    values: Sequence[float],
    verdicts: Sequence[str | None],
    margin: float,
) -> list[dict[str, object]]:
    """Return the drift alarms of one KPI's nightly series (rows of :data:`COLUMNS`)."""
    spec = KPI_BY_NAME.get(kpi)
    keep = [k for k, v in enumerate(values) if np.isfinite(v)]
    if len(keep) < 2 or not np.isfinite(margin):
        return []
    vals = [float(values[k]) for k in keep]
    days = [nights[k] for k in keep]
    said = [verdicts[k] for k in keep]
    steps = worse_steps(vals, spec.higher_is_better if spec is not None else True)
    rows: list[dict[str, object]] = []
    for alarm in merged(decline_alarms(steps, margin) + cusum_alarms(steps, margin)):
        caught = [days[k] for k in range(alarm.start + 1, alarm.stop + 1) if said[k] == WORSE]
        rows.append(
            {
                "kpi": kpi,
                "rule": alarm.rule,
                "first_night": days[alarm.start],
                "last_night": days[alarm.stop],
                "nights": alarm.stop - alarm.start + 1,
                "first_value": vals[alarm.start],
                "last_value": vals[alarm.stop],
                "change": vals[alarm.stop] - vals[alarm.start],
                "margin": margin,
                "caught_by": ", ".join(caught),
                "caught": bool(caught),
            }
        )
    return rows


def drifts(series: pd.DataFrame, margins: Mapping[str, float] | None = None) -> pd.DataFrame:
    """Return every drift alarm of a nightly series (``fleet.history.nightly_series``).

    Args:
        series: One row per ``night`` and ``kpi`` with ``value`` and ``verdict``.
        margins: Margins by KPI name that replace the defaults.
    """
    rows: list[dict[str, object]] = []
    for kpi, group in series.sort_values("night").groupby("kpi", sort=True):
        values = group["value"].astype(float).tolist()
        verdicts = [None if pd.isna(v) else str(v) for v in group["verdict"]]
        margin = drift_margin(str(kpi), values, margins or {})
        rows += kpi_drifts(str(kpi), group["night"].tolist(), values, verdicts, margin)
    return pd.DataFrame(rows, columns=COLUMNS)
