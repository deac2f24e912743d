"""The release gate (``--fail-on-regression KPI[:MARGIN]``) and the display of verdicts.

The gate passes only what it could judge: a gated KPI passes when its interval's worse bound
stays inside the margin (non-inferiority). It fails (exit 4) on a KPI the candidate lost, or a
KPI whose change is significantly worse after Holm's correction across the gated KPIs and whose
interval reaches past the margin. Anything else it cannot decide (exit 3): too few drives, no
matched drive or sequence, or an interval that reaches past the margin without a significant
change.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.errors import ExitCode, UsageError
from superlane_tools.fleet.bootstrap import LOST, TOO_FEW, UNAVAILABLE, FloatArray, holm
from superlane_tools.fleet.compare import Comparison
from superlane_tools.fleet.kpis import KPIS

PRIMARY_KPIS = (
    "availability_frames.super",
    "curvature_rmse_dynamics.super_path",
    "lane_width_bias",
    "coverage.fit",
)
"""The few KPIs the docs recommend gating on (each gated KPI costs power under Holm)."""


class GateRule(NamedTuple):
    """One ``--fail-on-regression`` rule.

    Attributes:
        pattern: A KPI name, a family (``availability_frames``: all its methods) or ``all``.
        margin: Non-inferiority margin in the KPI's display unit (percentage points for
            ratios); None: the KPI's documented margin.
    """

    pattern: str
    margin: float | None = None

    def matches(self, kpi: str) -> bool:
        """Return whether the rule covers ``kpi``."""
        return self.pattern in ("all", kpi, kpi.partition(".")[0])

    def text(self) -> str:
        """Return the rule as given on the command line."""
        return self.pattern if self.margin is None else f"{self.pattern}:{self.margin:g}"


def parse_rule(text: str) -> GateRule:
    """Parse ``KPI[:MARGIN]``.

    Raises:
        UsageError: For an unknown KPI or a margin that is not a number >= 0.
    """
    name, _, value = text.partition(":")
    known = {k.name for k in KPIS} | {k.family for k in KPIS} | {"all"}
    if name not in known:
        families = ", ".join(sorted({k.family for k in KPIS}))
        raise UsageError(
            f"--fail-on-regression: unknown KPI {name!r} (known: all, {families}, "
            "or family.method as in compare.md)"
        )
    if not value:
        return GateRule(name)
    try:
        margin = float(value)
    except ValueError:
        margin = math.nan
    if not margin >= 0:
        raise UsageError(f"--fail-on-regression {text}: the margin must be a number >= 0")
    return GateRule(name, margin)


class GateResult(NamedTuple):
    """What the gate decided.

    Attributes:
        code: ``OK`` (passed), ``PARTIAL`` (3: cannot decide) or ``REGRESSION`` (4).
        regressions: One line per failing KPI.
        undecided: One line per reason the gate cannot decide.
        gated: The KPIs judged.
        statement: How (margins, Holm across the gated KPIs).
    """

    code: ExitCode
    regressions: tuple[str, ...] = ()
    undecided: tuple[str, ...] = ()
    gated: tuple[str, ...] = ()
    statement: str = ""


def _display_scale(unit: str) -> float:
    return 100.0 if unit == "ratio" else 1.0


def _rule_for(kpi: str, rules: Sequence[GateRule]) -> GateRule | None:
    """Return the most specific rule covering ``kpi`` (name, then family, then ``all``)."""
    for pattern in (kpi, kpi.partition(".")[0], "all"):
        for rule in rules:
            if rule.pattern == pattern:
                return rule
    return None


def _fleet_problem(comparison: Comparison, min_drives: int) -> str:
    matched, n_b, n_c = comparison.n_drives()
    if not comparison.paired and comparison.unaligned:
        return (
            f"no matched sequences: the {len(comparison.unaligned)} drives of the same "
            "recordings have sequences that do not line up (another kpi.window_s?)"
        )
    if not comparison.paired:
        return (
            f"no matched drive ({n_b} base, {n_c} candidate drives): unpaired fleets "
            "cannot be judged"
        )
    if matched < min_drives:
        return f"too few drives ({matched} matched, a verdict needs {min_drives})"
    return ""


def judge_gate(comparison: Comparison, rules: Sequence[GateRule]) -> GateResult:
    """Return the gate's decision on a comparison's fleet rows (see the module docstring)."""
    if not rules:
        return GateResult(ExitCode.OK)
    fleet = comparison.fleet_rows()
    gated = []
    for row in fleet.to_dict("records"):
        rule = _rule_for(str(row["kpi"]), rules)
        if rule is None:
            continue
        explicit = rule.pattern == row["kpi"]
        if row["verdict"] == UNAVAILABLE and not explicit:
            continue  # a family or `all`: KPIs no run measured are not judged
        gated.append((row, rule))
    alpha = 1.0 - comparison.params.confidence
    names = tuple(str(r["kpi"]) for r, _ in gated)
    statement = (
        f"gate over {len(names)} KPIs ({', '.join(r.text() for r in rules)}): passes when every "
        f"interval's worse bound stays inside the margin; fails on a lost KPI or a change "
        f"significantly worse after Holm's correction across the {len(names)} gated KPIs "
        f"(family-wise {alpha:.0%}) that reaches past the margin"
    )
    regress = [_lost_line(r) for r, _ in gated if r["verdict"] == LOST]
    problem = _fleet_problem(comparison, comparison.params.min_drives)
    if regress or problem:
        return GateResult(
            ExitCode.REGRESSION if regress else ExitCode.PARTIAL,
            tuple(regress),
            (problem,) if problem else (),
            names,
            statement,
        )
    undecided = []
    judged = []
    for row, rule in gated:
        if row["verdict"] == UNAVAILABLE:
            undecided.append(f"{row['kpi']}: no value in the base (nothing to judge)")
        elif row["verdict"] == TOO_FEW:
            undecided.append(f"{row['kpi']}: too few drives ({row['n_drives']})")
        else:
            judged.append((row, rule))
    margins, goodness = [], []
    for row, rule in judged:
        scale = _display_scale(str(row["unit"]))
        margins.append(float(row["margin"]) if rule.margin is None else rule.margin / scale)
        sign = 1.0 if row["higher_is_better"] else -1.0
        goodness.append([sign * float(row[c]) for c in ("delta", "ci_low", "ci_high")])
    p = np.array([float(r["p_value"]) for r, _ in judged], dtype=np.float64)
    g = np.array(goodness, dtype=np.float64).reshape(-1, 3)
    fails, open_ = gate_flags(p, g[:, 0], np.minimum(g[:, 1], g[:, 2]), np.array(margins), alpha)
    for (row, _), margin, fail, undecidable in zip(judged, margins, fails, open_, strict=True):
        if fail:
            line = _line(row, margin)
            regress.append(f"{line}; significant after Holm (p = {row['p_value']:.2g})")
        elif undecidable:
            undecided.append(f"{_line(row, margin)}; not significant after Holm: cannot decide")
    code = ExitCode.REGRESSION if regress else ExitCode.PARTIAL if undecided else ExitCode.OK
    return GateResult(code, tuple(regress), tuple(undecided), names, statement)


def gate_flags(
    p_values: FloatArray,
    change: FloatArray,
    worse_bound: FloatArray,
    margins: FloatArray,
    alpha: float,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Return which gated KPIs fail the gate and which leave it undecided.

    Args:
        p_values: Two-sided p-values of "no change" (Holm across them).
        change: The changes, signed so that positive is better.
        worse_bound: The intervals' worse bounds, signed the same way.
        margins: The margins (>= 0), in the KPIs' units.
        alpha: Family-wise level of Holm's procedure.

    A KPI whose worse bound reaches the margin (``<= -margin``) fails when its change is worse
    and significant after Holm, else leaves the gate undecided; one inside the margin passes.
    """
    crosses = ~(worse_bound > -margins)
    fails = crosses & holm(p_values, alpha) & (change < 0)
    return fails, crosses & ~fails


def _lost_line(row: Mapping[Hashable, Any]) -> str:
    value = _value(float(str(row["base"])), str(row["unit"]))
    return f"{row['kpi']}: measured by the base ({value}), by the candidate on no drive"


def _line(row: Mapping[Hashable, Any], margin: float) -> str:
    unit = str(row["unit"])
    scale, suffix = (100.0, " pp") if unit == "ratio" else (1.0, f" {unit}")
    return (
        f"{row['kpi']}: {_value(float(str(row['base'])), unit)} -> "
        f"{_value(float(str(row['candidate'])), unit)}, change "
        f"{_change(float(str(row['delta'])), unit)}, "
        + (
            "the same on every drive"
            if row["note"]
            else "interval " + _ci(float(str(row["ci_low"])), float(str(row["ci_high"])), unit, "")
        )
        + f", past the margin {scale * margin:.3g}{suffix} ({row['n_drives']} drives)"
    )


def regressions(comparison: Comparison, rules: Sequence[GateRule]) -> list[str]:
    """Return one line per gated KPI that fails the gate (see :func:`judge_gate`)."""
    return list(judge_gate(comparison, rules).regressions)


def _value(v: float, unit: str) -> str:
    if not math.isfinite(v):
        return "n/a"
    if unit == "ratio":
        return f"{100 * v:.1f}%"
    return f"{v:.3g} {unit}"


def _change(d: float, unit: str) -> str:
    if not math.isfinite(d):
        return "n/a"
    return f"{100 * d:+.2f} pp" if unit == "ratio" else f"{d:+.3g} {unit}"


def _ci(lo: float, hi: float, unit: str, note: str) -> str:
    if note:
        return "none: the same change on every drive"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "n/a"
    scale, suffix = (100.0, " pp") if unit == "ratio" else (1.0, f" {unit}")
    return f"[{scale * lo:+.3g}, {scale * hi:+.3g}]{suffix}"


def verdict_margin(m: float, unit: str) -> str:
    """Return a margin in its display unit (percentage points for ratios)."""
    if not math.isfinite(m):
        return "n/a"
    return f"{100 * m:.3g} pp" if unit == "ratio" else f"{m:.3g} {unit}"


def _verdict(verdict: str, n_drives: int) -> str:
    return f"{verdict} ({n_drives})" if verdict == TOO_FEW else verdict


def verdict_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Return the rows (one per KPI) as a display table: values with units, the change's CI."""
    units = rows["unit"].astype(str).tolist()
    return pd.DataFrame(
        {
            "KPI": rows["label"],
            "name": rows["kpi"],
            "base": [_value(v, u) for v, u in zip(rows["base"], units, strict=True)],
            "candidate": [_value(v, u) for v, u in zip(rows["candidate"], units, strict=True)],
            "change": [_change(d, u) for d, u in zip(rows["delta"], units, strict=True)],
            "95% CI of the change": [
                _ci(lo, hi, u, str(note))
                for lo, hi, u, note in zip(
                    rows["ci_low"], rows["ci_high"], units, rows["note"], strict=True
                )
            ],
            "margin": [verdict_margin(m, u) for m, u in zip(rows["margin"], units, strict=True)],
            "drives": rows["n_drives"],
            "sequences": rows["n_sequences"],
            "verdict": [
                _verdict(str(v), int(n))
                for v, n in zip(rows["verdict"], rows["n_drives"], strict=True)
            ],
        }
    )
