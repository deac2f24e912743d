"""``slt mine``: frames worth labelling from runs, exported with pre-annotations."""

from superlane_tools.commands.mine.run import MineResult, mine_runs

__all__ = ["MineResult", "mine_runs"]
