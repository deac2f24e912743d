"""What every benchmark keeps beside its numbers: the machine's load, and its JSON results.

The machine is shared and its speed moves from day to day: every result file carries
``uptime``'s line. Benchmarks import this module by name (``python benchmarks/bench_X.py`` puts
``benchmarks/`` first on the path).
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any


def uptime() -> str:
    """Return ``uptime``'s line (the load average alone where ``uptime`` cannot run)."""
    try:
        done = subprocess.run(["uptime"], capture_output=True, text=True, check=False)
    except OSError:
        return f"load average {os.getloadavg()}"
    return done.stdout.strip()


def write_results(out: dict[str, Any], path: Path) -> None:
    """Write a benchmark's results as indented JSON to ``path`` and print them."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(out, indent=2))
