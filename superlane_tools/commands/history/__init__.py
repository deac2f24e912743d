"""``slt history``: the fleet's KPIs night over night, model changes and drifts no gate caught."""

from superlane_tools.commands.history.run import HistoryParams, HistoryResult, history_report

__all__ = ["HistoryParams", "HistoryResult", "history_report"]
