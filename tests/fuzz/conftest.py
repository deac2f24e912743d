"""Make the fuzz harness module importable by the fuzz tests (and by benchmarks/fuzz.py)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
