"""Calibrate ``slt compare``: false alarms and power of its intervals, verdicts and gate.

Run: ``python benchmarks/bench_compare_calibration.py [--fleets 1000] [--resamples 999]
[--sizes 5,8,10,30,200] [--real] [--real-drives 10]``

**Simulated fleets.** Many fleets of ``--sizes`` drives, 10 sequences (30 s, 300 frames) per
drive, per-sequence KPI sums ``(num, den)`` for five KPIs, each with a drive level, a sequence
level and a **drive x run** random effect (a change helps some drives and hurts others), both
runs drawn the same way (A/A: no true fleet change, by symmetry), then with a stated effect on
every drive (:data:`EFFECTS`). Per KPI and fleet size: how often the 95 % interval excludes 0
and how often the verdict is better / worse, for the method ``slt compare`` uses (studentized
bootstrap over drives), a percentile bootstrap over drives, and the percentile bootstrap over
pooled sequences that ``slt compare`` used before; and the gate over four primary KPIs (Holm,
margins: :func:`superlane_tools.fleet.verdicts.gate_flags`): pass / cannot decide / fail, in A/A
and with an effect on one KPI. Every draw is vectorised over fleets (numpy, BLAS).

**Real A/A check** (``--real``): ``--real-drives`` simulated drives (5 s, 640x360, 10 frames/s,
cycling through the scenarios) reprocessed twice with the default configuration, the second
time at ``segmentation.process_width`` 608 instead of 640 (a harmless change), then compared by
``compare_runs`` with the gate on the primary KPIs; the fleet verdicts and the gate's decision
are recorded.

Writes ``benchmarks/results/compare_calibration.json`` and prints the tables of docs/compare.md.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.fleet import KPI_BY_NAME, PRIMARY_KPIS, judge
from superlane_tools.fleet.bootstrap import (
    interval,
    resample_counts,
    sign_flip_p,
    sign_flips,
    studentized,
)
from superlane_tools.fleet.verdicts import gate_flags

F = NDArray[np.float64]
SEQS, FRAMES = 10, 300
RESULTS = Path(__file__).parent / "results" / "compare_calibration.json"


def _expit(x: F) -> F:
    return np.asarray(1.0 / (1.0 + np.exp(-x)))


def _levels(
    rng: np.random.Generator, shape: tuple[int, int], sd: tuple[float, float, float]
) -> tuple[F, F]:
    """Return both runs' latent values: drive-and-sequence level plus drive x run and noise."""
    n_f, m = shape
    shared = rng.normal(0, sd[0], (n_f, m, SEQS))
    runs = [
        shared + rng.normal(0, sd[1], (n_f, m, 1)) + rng.normal(0, sd[2], (n_f, m, SEQS))
        for _ in range(2)
    ]
    return runs[0], runs[1]


def _ratio(
    mu: float, sd_drive: float, sds: tuple[float, float, float]
) -> Callable[..., tuple[F, ...]]:
    def draw(rng: np.random.Generator, n_f: int, m: int, effect: float) -> tuple[F, ...]:
        base_level = rng.normal(mu, sd_drive, (n_f, m, 1))
        lb, lc = _levels(rng, (n_f, m), sds)
        den = np.full((n_f, m, SEQS), float(FRAMES))
        nb = rng.binomial(FRAMES, _expit(base_level + lb)).astype(float)
        nc = rng.binomial(FRAMES, _expit(base_level + lc + effect)).astype(float)
        return nb, den, nc, den

    return draw


def _rmse(rng: np.random.Generator, n_f: int, m: int, effect: float) -> tuple[F, ...]:
    level = rng.normal(np.log(3e-4), 0.4, (n_f, m, 1))
    lb, lc = _levels(rng, (n_f, m), (0.3, 0.15, 0.1))
    den = np.round(FRAMES * rng.uniform(0.5, 1.0, (n_f, m, 1))) * np.ones((1, 1, SEQS))
    nb = rng.chisquare(den) * np.exp(level + lb) ** 2
    nc = rng.chisquare(den) * (np.exp(level + lc) * np.exp(effect)) ** 2
    return nb, den, nc, den


def _bias(rng: np.random.Generator, n_f: int, m: int, effect: float) -> tuple[F, ...]:
    calib = rng.normal(0.0, 0.04, (n_f, m, 1))  # each car's camera calibration, metres
    lb, lc = _levels(rng, (n_f, m), (0.03, 0.01, 0.01))
    den = np.round(FRAMES * rng.uniform(0.6, 1.0, (n_f, m, 1))) * np.ones((1, 1, SEQS))
    return den * (calib + lb), den, den * (calib + lc + effect), den


def _cost(rng: np.random.Generator, n_f: int, m: int, effect: float) -> tuple[F, ...]:
    level = rng.normal(np.log(2.5), 0.25, (n_f, m, 1))
    lb, lc = _levels(rng, (n_f, m), (0.1, 0.04, 0.03))
    den = np.round(FRAMES * rng.uniform(0.8, 1.0, (n_f, m, 1))) * np.ones((1, 1, SEQS))
    return den * np.exp(level + lb), den, den * (np.exp(level + lc) + effect), den


MODELS: dict[str, tuple[Callable[..., tuple[F, ...]], str]] = {
    "availability_frames.super": (
        _ratio(2.2, 0.8, (0.6, 0.25, 0.2)),
        "logit: drive N(2.2, 0.8), sequence N(0, 0.6), drive x run N(0, 0.25), noise N(0, 0.2)",
    ),
    "curvature_rmse_dynamics.super_path": (
        _rmse,
        "log RMS: drive N(log 3e-4, 0.4), sequence N(0, 0.3), drive x run N(0, 0.15), noise "
        "N(0, 0.1); 50-100 % of frames with a value",
    ),
    "lane_width_bias": (
        _bias,
        "bias (m): camera calibration per drive N(0, 0.04), sequence N(0, 0.03), drive x run "
        "N(0, 0.01), noise N(0, 0.01)",
    ),
    "ego_pair_share": (
        _ratio(3.0, 0.7, (0.5, 0.2, 0.2)),
        "logit: drive N(3, 0.7), sequence N(0, 0.5), drive x run N(0, 0.2), noise N(0, 0.2)",
    ),
    "fit_cost": (
        _cost,
        "log J: drive N(log 2.5, 0.25), sequence N(0, 0.1), drive x run N(0, 0.04), noise "
        "N(0, 0.03)",
    ),
}
EFFECTS: dict[str, tuple[float, str]] = {
    "availability_frames.super": (-0.5, "-0.5 on the logit of every drive (about -5 pp)"),
    "curvature_rmse_dynamics.super_path": (np.log(1.3), "RMSE x1.3 on every drive"),
    "lane_width_bias": (0.18, "camera height 5 % off: +0.18 m lane width on every drive"),
    "ego_pair_share": (-0.5, "-0.5 on the logit of every drive (about -2.5 pp)"),
    "fit_cost": (0.5, "+0.5 J on every drive"),
}
GATED = (*(k for k in PRIMARY_KPIS if k in MODELS), "ego_pair_share")
"""The simulated gate's KPIs (the primary KPIs the simulation has, coverage.fit replaced by
ego_pair_share)."""


def _sequence_percentile(
    name: str, sums: tuple[F, ...], n_resamples: int, rng: np.random.Generator
) -> tuple[F, F, F]:
    """Return the delta and 95 % percentile interval over pooled sequences (the old method)."""
    kpi = KPI_BY_NAME[name]
    n_f = sums[0].shape[0]
    flat = [a.reshape(n_f, -1) for a in sums]
    n = flat[0].shape[1]
    counts = resample_counts(n, n_resamples, rng)

    def value(num: F, den: F) -> F:
        v = kpi.pooled(num, den)
        return np.abs(v) if kpi.per_drive == "abs" else v  # the old |pooled signed mean|

    drawn = counts @ np.concatenate(flat, axis=0).T  # (B, 4 * fleets)
    nb, db, nc, dc = (drawn[:, k * n_f : (k + 1) * n_f].T for k in range(4))
    d_star = value(nc, dc) - value(nb, db)
    delta = value(flat[2].sum(1), flat[3].sum(1)) - value(flat[0].sum(1), flat[1].sum(1))
    lo, hi = np.quantile(d_star, [0.025, 0.975], axis=1)
    return delta, lo, hi


def _drive_sums(name: str, sums: tuple[F, ...]) -> tuple[F, ...]:
    nb, db, nc, dc = (a.sum(axis=2) for a in sums)
    if KPI_BY_NAME[name].per_drive == "abs":
        nb, nc = np.abs(nb), np.abs(nc)
    return nb, db, nc, dc


def _one(name: str, m: int, effect: float, args: argparse.Namespace, seed: int) -> dict[str, Any]:
    """Return the interval methods' results on ``args.fleets`` fleets of ``m`` drives."""
    rng = np.random.default_rng(seed)
    kpi = KPI_BY_NAME[name]
    sums = MODELS[name][0](rng, args.fleets, m, effect)
    nb, db, nc, dc = _drive_sums(name, sums)
    counts = resample_counts(m, args.resamples, rng)
    s = studentized((nb, db), (nc, dc), kpi.transform, counts)
    lo, hi, _ = interval(s, 0.95)
    p = sign_flip_p((nb, db), (nc, dc), kpi.transform, sign_flips(m, args.resamples, rng))
    significant = p < 0.05
    p_lo, p_hi = np.nanquantile(s.d_star, [0.025, 0.975], axis=1)
    sign = 1.0 if kpi.higher_is_better else -1.0
    from scipy.stats import t as student_t

    t_crit = float(student_t.ppf(0.975, m - 1))
    verdicts = [
        judge(kpi, kpi.margin, a, b, sig) for a, b, sig in zip(lo, hi, significant, strict=True)
    ]
    out: dict[str, Any] = {
        "kpi": name,
        "drives": m,
        "mean_delta": float(np.mean(s.delta)),
        "sign_flip": {"significant": float(np.mean(significant))},
        "bootstrap_t": {
            "excludes_0": float(np.mean((lo > 0) | (hi < 0))),  # the hull (slt compare)
            "better_or_worse": float(np.mean([v in ("better", "worse") for v in verdicts])),
            "worse": float(np.mean([v == "worse" for v in verdicts])),
            "equivalent": float(np.mean([v == "equivalent within margin" for v in verdicts])),
        },
        "drive_percentile": {"excludes_0": float(np.mean((p_lo > 0) | (p_hi < 0)))},
        "t_linearised": {"excludes_0": float(np.mean(np.abs(s.delta) > t_crit * s.se))},
        "_gate": (p, sign * s.delta, np.minimum(sign * lo, sign * hi)),
        "_old_worse": None,
    }
    if m * SEQS <= args.max_old_sequences:
        _, o_lo, o_hi = _sequence_percentile(name, sums, args.old_resamples, rng)
        old_worse = np.maximum(sign * o_lo, sign * o_hi) < 0
        out["sequence_percentile_before"] = {
            "excludes_0": float(np.mean((o_lo > 0) | (o_hi < 0))),
            "worse": float(np.mean(old_worse)),
        }
        out["_old_worse"] = old_worse
    return out


def _gate(results: dict[str, dict[str, Any]], alpha: float = 0.05) -> dict[str, float]:
    """Return the share of fleets the gate passes, cannot decide and fails."""
    parts = [results[k]["_gate"] for k in GATED]
    p = np.stack([x[0] for x in parts], axis=1)
    change = np.stack([x[1] for x in parts], axis=1)
    worse = np.stack([x[2] for x in parts], axis=1)
    margins = np.array([KPI_BY_NAME[k].margin for k in GATED])
    n_fail = n_open = 0
    for i in range(len(p)):
        fails, undecided = gate_flags(p[i], change[i], worse[i], margins, alpha)
        n_fail += bool(fails.any())
        n_open += bool(undecided.any() and not fails.any())
    n = len(p)
    old = [results[k]["_old_worse"] for k in GATED]
    complete = all(o is not None for o in old)
    any_worse = np.stack(old, axis=1).any(axis=1).mean() if complete else float("nan")
    return {
        "fail": n_fail / n,
        "cannot_decide": n_open / n,
        "pass": 1 - (n_fail + n_open) / n,
        "before_any_worse": float(any_worse),
    }


def simulate(args: argparse.Namespace) -> dict[str, Any]:
    """Run every KPI, fleet size and scenario (A/A, then each KPI's effect)."""
    rows, gates = [], []
    seed = args.seed
    for m in args.sizes:
        t0 = time.perf_counter()
        scenarios = {"A/A": None, **{f"effect on {k}": k for k in GATED}}
        for scenario, target in scenarios.items():
            res = {}
            for name in MODELS:
                if target is not None and name not in (target, *GATED):
                    continue
                seed += 1
                effect = EFFECTS[name][0] if name == target else 0.0
                res[name] = _one(name, m, effect, args, seed)
                if target is None or name == target:
                    kept = {k: v for k, v in res[name].items() if not k.startswith("_")}
                    rows.append({"scenario": scenario, **kept})
            gates.append({"drives": m, "scenario": scenario, **_gate(res)})
        print(f"{m} drives: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return {"kpis": rows, "gate": gates}


def real_aa(n_drives: int) -> dict[str, Any]:
    """Reprocess ``n_drives`` simulated drives twice (process width 640 and 608) and compare."""
    from superlane_tools.commands.compare import CompareParams, compare_runs
    from superlane_tools.commands.reprocess import reprocess
    from superlane_tools.drive.config import ReprocessConfig
    from superlane_tools.fleet import parse_rule
    from superlane_tools.reporting.layout import CompareLayout
    from superlane_tools.reporting.run_folder import staged_run
    from superlane_tools.simulation import SCENARIOS
    from superlane_tools.simulation.drive import simulate_drive

    names = [s for s in SCENARIOS if s not in ("night", "tunnel")]
    base_cfg = ReprocessConfig().with_overrides(
        {"kpi.window_s": 1.0, "output.plots": False, "output.example_frames": 0}
    )
    configs = {
        "base": base_cfg,
        "width608": base_cfg.with_overrides({"segmentation.process_width": 608}),
    }
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for k in range(n_drives):
            rec = work / f"drive{k:02d}.mcap"
            simulate_drive(
                names[k % len(names)], 5.0, 100 + k, "mcap", 640, 360, False, rec, fps=10.0
            )
            for run, cfg in configs.items():
                with staged_run(work / run / rec.stem) as stage:
                    reprocess(rec, stage, cfg)
        gate = tuple(parse_rule(k) for k in PRIMARY_KPIS)
        result = compare_runs(
            work / "base", work / "width608", work / "cmp", CompareParams(gate=gate, plots=False)
        )
        fleet = result.comparison.fleet_rows()
        report = CompareLayout(work / "cmp").report.read_text(encoding="utf-8")
    return {
        "drives": n_drives,
        "change": "segmentation.process_width 640 -> 608",
        "wall_s": round(time.perf_counter() - t0, 1),
        "verdicts": {str(k): str(v) for k, v in zip(fleet["kpi"], fleet["verdict"], strict=True)},
        "verdict_counts": {str(k): int(v) for k, v in fleet["verdict"].value_counts().items()},
        "gate_code": int(result.gate.code),
        "gate_lines": [*result.gate.regressions, *result.gate.undecided],
        "differences": result.differences[["key", "base", "candidate"]].to_dict("records"),
        "report_head": report[:1500],
    }


def _table(data: dict[str, Any]) -> str:
    lines = [
        "| KPI | scenario | drives | sign-flip p < 5 % | interval excludes 0 | better/worse "
        "verdicts | t over drives excludes 0 | drive percentile excludes 0 | sequence percentile "
        "excludes 0 (before) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in data["kpis"]:
        old = r.get("sequence_percentile_before", {}).get("excludes_0")
        lines.append(
            f"| `{r['kpi']}` | {r['scenario']} | {r['drives']} | "
            f"{r['sign_flip']['significant']:.1%} | {r['bootstrap_t']['excludes_0']:.1%} | "
            f"{r['bootstrap_t']['better_or_worse']:.1%} | {r['t_linearised']['excludes_0']:.1%} | "
            f"{r['drive_percentile']['excludes_0']:.1%} | "
            f"{'-' if old is None else f'{old:.1%}'} |"
        )
    lines += [
        "",
        "| scenario | drives | gate passes | cannot decide (3) | fails (4) | before: any worse |",
        "|---|---|---|---|---|---|",
    ]
    for g in data["gate"]:
        before = g["before_any_worse"]
        lines.append(
            f"| {g['scenario']} | {g['drives']} | {g['pass']:.1%} | {g['cannot_decide']:.1%} | "
            f"{g['fail']:.1%} | {'-' if math.isnan(before) else f'{before:.1%}'} |"
        )
    return "\n".join(lines)


def main() -> int:
    """Run the calibration; write the results JSON and print the tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--fleets", type=int, default=1000, help="simulated fleets per setting")
    ap.add_argument("--resamples", type=int, default=999, help="bootstrap resamples")
    ap.add_argument("--sizes", default="5,8,10,30,200", help="fleet sizes (drives)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--old-resamples", type=int, default=499, help="resamples of the old method")
    ap.add_argument(
        "--max-old-sequences", type=int, default=300, help="old method up to this many sequences"
    )
    ap.add_argument("--real", action="store_true", help="also the real A/A check (reprocess runs)")
    ap.add_argument("--real-drives", type=int, default=10)
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args()
    args.sizes = [int(s) for s in args.sizes.split(",")]
    t0, c0 = time.perf_counter(), time.process_time()
    data: dict[str, Any] = {
        "command": " ".join(["python", *sys.argv]),
        "data": "simulated per-sequence KPI sums (no recordings)",
        "fleets": args.fleets,
        "resamples": args.resamples,
        "sequences_per_drive": SEQS,
        "frames_per_sequence": FRAMES,
        "models": {k: v[1] for k, v in MODELS.items()},
        "effects": {k: v[1] for k, v in EFFECTS.items()},
        "margins": {k: KPI_BY_NAME[k].margin for k in MODELS},
        "gated": list(GATED),
        **simulate(args),
    }
    data["simulation_wall_s"] = round(time.perf_counter() - t0, 1)
    data["simulation_cpu_s"] = round(time.process_time() - c0, 1)
    if args.real:
        data["real_aa"] = real_aa(args.real_drives)
    data["load_average"] = os.getloadavg()
    data["max_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, indent=1, default=float) + "\n", encoding="utf-8")
    print(_table(data))
    if "real_aa" in data:
        print(
            json.dumps({k: v for k, v in data["real_aa"].items() if k != "report_head"}, indent=1)
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
