"""compare_fleets on synthetic sequence sums: drives pooled, categories, lost and unaligned runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.fleet import (
    DESCRIPTIVE,
    KPIS,
    LOST,
    TOO_FEW,
    UNPAIRED,
    WORSE,
    BootstrapParams,
    DriveRun,
    compare_fleets,
)

PARAMS = BootstrapParams(n_resamples=199)


def _seqs(rng: np.random.Generator, drop: float, start: int = 0, lose: str = "") -> pd.DataFrame:
    """Sums of 3 sequences of every KPI: availability-like values, ``drop`` lower."""
    rows = []
    for k in KPIS:
        for seq in range(3):
            den = 100.0 if k.name != lose else 0.0
            num = den * (0.9 - drop + rng.normal(0, 0.01)) if k.unit == "ratio" else den * 0.5
            rows.append(
                (seq, seq * 10, seq * 10 + 10, start + seq * 10**9, "", k.name, num, den, den)
            )
    columns = ["sequence", "start", "stop", "start_ns", "category", "kpi", "num", "den", "measured"]
    return pd.DataFrame(rows, columns=columns)


def _drive(k: int, category: str, tag: str = "h") -> DriveRun:
    return DriveRun(f"{tag}{k}", f"d{k}", Path(f"/r/d{k}"), category, "", {})


def test_drives_pool_into_the_fleet_and_categories_need_their_own_drives() -> None:
    rng = np.random.default_rng(0)
    cats = ["highway"] * 8 + ["urban"] * 4
    base = [(_drive(k, c), _seqs(rng, 0.0)) for k, c in enumerate(cats)]
    cand = [(_drive(k, c), _seqs(rng, 0.1)) for k, c in enumerate(cats)]
    cmp = compare_fleets(base, cand, PARAMS)
    fleet = cmp.fleet_rows().set_index("kpi")
    row = fleet.loc["availability_frames.super"]
    assert (row["n_drives"], row["n_sequences"], row["verdict"]) == (12, 36, WORSE)
    assert cmp.n_drives() == (12, 12, 12)
    assert cmp.sequences == (36, 36, 36)
    t = cmp.table
    cat = t[(t["scope"] == "category") & (t["kpi"] == "availability_frames.super")]
    assert cat.set_index("category")["verdict"].to_dict() == {"highway": TOO_FEW, "urban": TOO_FEW}
    drives = t[t["scope"] == "drive"]
    assert (drives["verdict"] == DESCRIPTIVE).all()
    assert drives["ci_low"].isna().all()
    assert len(t[t["scope"] == "sequence"]) == 36 * len(KPIS)


def test_a_kpi_the_candidate_measured_nowhere_is_lost() -> None:
    rng = np.random.default_rng(1)
    base = [(_drive(k, "c"), _seqs(rng, 0.0)) for k in range(10)]
    cand = [(_drive(k, "c"), _seqs(rng, 0.0, lose="fit_cost")) for k in range(10)]
    fleet = compare_fleets(base, cand, PARAMS).fleet_rows().set_index("kpi")
    assert fleet.at["fit_cost", "verdict"] == LOST
    assert fleet.at["fit_cost", "base"] == 0.5  # the base's own value, shown
    assert np.isnan(fleet.at["fit_cost", "candidate"])


def test_sequences_that_do_not_line_up_and_other_recordings_are_not_judged() -> None:
    rng = np.random.default_rng(2)
    base = [(_drive(k, "c"), _seqs(rng, 0.0)) for k in range(10)]
    moved = [(_drive(k, "c"), _seqs(rng, 0.0, start=1)) for k in range(10)]
    cmp = compare_fleets(base, moved, PARAMS)
    assert not cmp.paired
    assert len(cmp.unaligned) == 10
    assert cmp.sequences == (0, 30, 30)
    assert (cmp.fleet_rows()["verdict"] == UNPAIRED).all()
    other = [(_drive(k, "c", tag="x"), _seqs(rng, 0.0)) for k in range(10)]
    cmp = compare_fleets(base, other, PARAMS)
    assert (not cmp.paired, len(cmp.only_base), len(cmp.only_candidate)) == (True, 10, 10)
    assert cmp.fleet_rows()["ci_low"].isna().all()
