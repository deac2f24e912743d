"""``slt compare``: a candidate fleet run against a base, with intervals, verdicts and spans."""

from superlane_tools.commands.compare.run import CompareParams, CompareResult, compare_runs

__all__ = ["CompareParams", "CompareResult", "compare_runs"]
