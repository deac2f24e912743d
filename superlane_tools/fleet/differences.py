"""What differs between two runs: tool versions, model SHA-256s, configuration keys (provenance)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import pandas as pd

from superlane_tools.fleet.runs import DriveRun

IGNORED_CONFIG = frozenset({"kpi.category", "kpi.manifest", "output.plots"})
"""Keys that differ between drives of one run by nature, or do not change results."""
DIFF_COLUMNS = ("what", "key", "base", "candidate")


def _flatten(value: Any, prefix: str = "") -> dict[str, str]:
    if isinstance(value, Mapping):
        out: dict[str, str] = {}
        for k, v in value.items():
            out |= _flatten(v, f"{prefix}.{k}" if prefix else str(k))
        return out
    return {prefix: str(value)}


def _values(drives: Iterable[DriveRun]) -> dict[tuple[str, str], set[str]]:
    seen: dict[tuple[str, str], set[str]] = {}

    def add(what: str, key: str, value: str) -> None:
        seen.setdefault((what, key), set()).add(value)

    for d in drives:
        add("tool version", "tool_version", d.tool_version or "unknown")
        for model, sha in (d.provenance.get("models") or {}).items():
            add("model sha256", str(model), str(sha))
        for key, value in _flatten(d.provenance.get("config") or {}).items():
            if key not in IGNORED_CONFIG and not key.startswith("resolved.streams"):
                add("config", key, value)
    return seen


def run_differences(base: Iterable[DriveRun], candidate: Iterable[DriveRun]) -> pd.DataFrame:
    """Return what differs between two runs, tool versions first, then models, then config.

    A value seen in one run only (a model the other did not use, a key one lacks) is listed
    with ``-`` on the other side; values that vary between the drives of one run are joined.
    """
    vb, vc = _values(base), _values(candidate)
    order = {"tool version": 0, "model sha256": 1, "config": 2}
    rows = []
    for what, key in sorted(vb.keys() | vc.keys(), key=lambda k: (order[k[0]], k[1])):
        b, c = vb.get((what, key), set()), vc.get((what, key), set())
        if b != c:
            rows.append(
                {
                    "what": what,
                    "key": key,
                    "base": ", ".join(sorted(b)) or "-",
                    "candidate": ", ".join(sorted(c)) or "-",
                }
            )
    return pd.DataFrame(rows, columns=list(DIFF_COLUMNS))
