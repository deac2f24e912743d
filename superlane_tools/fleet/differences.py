"""What differs between two runs: tool versions, backends, models, configuration (provenance).

Values are counted per drive, so a difference reads "base: classical on 3 of 3 drives;
candidate: onnx:super_seg_v4 on 3 of 3 drives". Only real differences are listed (the same
values on the same number of drives never are); the self-check's details are folded below the
headline.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping
from typing import Any

import pandas as pd

from superlane_tools.fleet.runs import DriveRun

IGNORED_CONFIG = frozenset({"kpi.category", "kpi.manifest", "output.plots"})
"""Keys that differ between drives of one run by nature, or do not change results."""
SELF_CHECK = "resolved.segmentation_self_check"
SELF_CHECK_KEYS = frozenset({"backend", "model", "plausible", "reason"})
"""The self-check's fields compared (its timings and per-trial scores differ between any runs)."""
BACKEND_KEY = "resolved.segmentation_backend"
DIFF_COLUMNS = ("what", "key", "base", "candidate", "folded")
_ORDER = {"tool version": 0, "segmentation backend": 1, "model sha256": 2, "config": 3}


def _flatten(value: Any, prefix: str = "") -> dict[str, str]:
    if isinstance(value, Mapping):
        out: dict[str, str] = {}
        for k, v in value.items():
            out |= _flatten(v, f"{prefix}.{k}" if prefix else str(k))
        return out
    return {prefix: str(value)}


def _config_items(config: Mapping[str, Any]) -> Iterable[tuple[str, str, str]]:
    for key, value in _flatten(config).items():
        if key in IGNORED_CONFIG or key.startswith("resolved.streams"):
            continue
        if key.startswith(SELF_CHECK):
            field = key[len(SELF_CHECK) + 1 :]
            if field in SELF_CHECK_KEYS:
                yield "self-check", field, value
        elif key == BACKEND_KEY:
            yield "segmentation backend", "segmentation backend", value
        else:
            yield "config", key, value


def _values(drives: Iterable[DriveRun]) -> tuple[dict[tuple[str, str], Counter[str]], int]:
    seen: dict[tuple[str, str], Counter[str]] = {}
    n = 0
    for d in drives:
        n += 1
        items = [("tool version", "tool_version", d.tool_version or "unknown")]
        items += [
            ("model sha256", str(m), str(sha))
            for m, sha in (d.provenance.get("models") or {}).items()
        ]
        items += list(_config_items(d.provenance.get("config") or {}))
        for what, key, value in items:
            seen.setdefault((what, key), Counter())[value] += 1
    return seen, n


def _describe(values: Counter[str], n: int, what: str) -> str:
    if not values:
        return "-"

    def show(v: str) -> str:
        return v[:12] if what == "model sha256" else v or "(none)"

    if len(values) == 1 and next(iter(values.values())) == n:
        return show(next(iter(values)))
    return ", ".join(f"{show(v)} on {c} of {n} drives" for v, c in sorted(values.items()))


def run_differences(base: Iterable[DriveRun], candidate: Iterable[DriveRun]) -> pd.DataFrame:
    """Return what differs between two runs: tool versions, the backend, models, configuration.

    A value seen in one run only (a model the other did not use, a key one lacks) is listed
    with ``-`` on the other side; values that vary between the drives of one run are counted
    (``classical on 2 of 3 drives, onnx:super_seg_v4 on 1 of 3 drives``). ``folded``: the
    self-check's fields (shown below the headline).
    """
    (vb, nb), (vc, nc) = _values(base), _values(candidate)
    rows = []
    keys = sorted(vb.keys() | vc.keys(), key=lambda k: (_ORDER.get(k[0], 4), k[1]))
    for what, key in keys:
        b = _describe(vb.get((what, key), Counter()), nb, what)
        c = _describe(vc.get((what, key), Counter()), nc, what)
        if b != c:
            rows.append((what, key, b, c, what == "self-check"))
    return pd.DataFrame(rows, columns=list(DIFF_COLUMNS))


def difference_lines(differences: pd.DataFrame) -> list[str]:
    """Return one line per real difference (the self-check's details excluded)."""
    lines = []
    shown = differences[~differences["folded"].astype(bool)]
    for what, key, base, cand in zip(
        shown["what"].astype(str),
        shown["key"].astype(str),
        shown["base"].astype(str),
        shown["candidate"].astype(str),
        strict=True,
    ):
        name = key if what in ("config", "segmentation backend") else what
        if what == "model sha256":
            name = f"model {key} (SHA-256)"
        lines.append(f"{name}: base {base}; candidate {cand}")
    return lines
