"""The drive simulator's renderer: a FrameScene in, image + leaf-id labels + corridor mask out."""

from superlane_tools.simulation.render.frame import render

__all__ = ["render"]
