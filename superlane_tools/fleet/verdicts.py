"""The release gate (``--fail-on-regression KPI[:THRESHOLD]``) and the display of verdicts."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import pandas as pd

from superlane_tools.errors import UsageError
from superlane_tools.fleet.bootstrap import WORSE
from superlane_tools.fleet.kpis import KPIS


class GateRule(NamedTuple):
    """One ``--fail-on-regression`` rule.

    Attributes:
        pattern: A KPI name, a family (``availability_frames``: all its methods) or ``all``.
        threshold: Tolerated worsening in the KPI's display unit (percentage points for
            ratios): a ``worse`` verdict fails only when the delta exceeds it.
    """

    pattern: str
    threshold: float = 0.0

    def matches(self, kpi: str) -> bool:
        """Return whether the rule covers ``kpi``."""
        return self.pattern in ("all", kpi, kpi.partition(".")[0])


def parse_rule(text: str) -> GateRule:
    """Parse ``KPI[:THRESHOLD]``.

    Raises:
        UsageError: For an unknown KPI or a threshold that is not a number >= 0.
    """
    name, _, value = text.partition(":")
    known = {k.name for k in KPIS} | {k.family for k in KPIS} | {"all"}
    if name not in known:
        families = ", ".join(sorted({k.family for k in KPIS}))
        raise UsageError(
            f"--fail-on-regression: unknown KPI {name!r} (known: all, {families}, "
            "or family.method as in compare.md)"
        )
    try:
        threshold = float(value) if value else 0.0
    except ValueError:
        threshold = math.nan
    if not threshold >= 0:
        raise UsageError(f"--fail-on-regression {text}: the threshold must be a number >= 0")
    return GateRule(name, threshold)


def _display_scale(unit: str) -> float:
    return 100.0 if unit == "ratio" else 1.0


def regressions(fleet: pd.DataFrame, rules: Sequence[GateRule]) -> list[str]:
    """Return one line per fleet KPI that a rule covers, judged worse beyond its threshold."""
    out = []
    for row in fleet.to_dict("records"):
        scale = _display_scale(str(row["unit"]))
        for rule in rules:
            if (
                rule.matches(str(row["kpi"]))
                and row["verdict"] == WORSE
                and abs(float(row["delta"])) * scale > rule.threshold
            ):
                out.append(
                    f"{row['kpi']}: {_value(float(row['base']), str(row['unit']))} -> "
                    f"{_value(float(row['candidate']), str(row['unit']))} (worse, 95% CI of "
                    f"the change {_ci(row['ci_low'], row['ci_high'], str(row['unit']))})"
                )
                break
    return out


def _value(v: float, unit: str) -> str:
    if not math.isfinite(v):
        return "n/a"
    if unit == "ratio":
        return f"{100 * v:.1f}%"
    return f"{v:.3g} {unit}"


def _ci(lo: float, hi: float, unit: str) -> str:
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "n/a"
    scale, suffix = (100.0, " pp") if unit == "ratio" else (1.0, f" {unit}")
    return f"[{scale * lo:+.3g}, {scale * hi:+.3g}]{suffix}"


def verdict_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Return the rows (one per KPI) as a display table: values with units, the change's CI."""
    return pd.DataFrame(
        {
            "KPI": rows["label"],
            "name": rows["kpi"],
            "base": [_value(v, u) for v, u in zip(rows["base"], rows["unit"], strict=True)],
            "candidate": [
                _value(v, u) for v, u in zip(rows["candidate"], rows["unit"], strict=True)
            ],
            "change": [
                "n/a"
                if not math.isfinite(d)
                else (f"{100 * d:+.2f} pp" if u == "ratio" else f"{d:+.3g} {u}")
                for d, u in zip(rows["delta"], rows["unit"], strict=True)
            ],
            "95% CI of the change": [
                _ci(lo, hi, u)
                for lo, hi, u in zip(rows["ci_low"], rows["ci_high"], rows["unit"], strict=True)
            ],
            "sequences": rows["n_sequences"],
            "verdict": rows["verdict"],
        }
    )
