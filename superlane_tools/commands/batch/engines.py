"""The batch engines by name: the factory over the local process pool and Ray.

Kept apart from :mod:`~superlane_tools.commands.batch.engine` (the types both engines import).
"""

from __future__ import annotations

from superlane_tools.commands.batch.engine import BatchEngine
from superlane_tools.commands.batch.params import BatchParams
from superlane_tools.errors import UsageError

ENGINES = ("local", "ray")


def make_engine(params: BatchParams, kind: str) -> BatchEngine:
    """Return the engine ``params`` asks for (not yet started).

    Raises:
        UsageError: If the engine name is unknown.
    """
    if params.engine == "local":
        from superlane_tools.commands.batch.local import LocalEngine

        if params.ray_address:
            raise UsageError("--ray-address needs --engine ray")
        return LocalEngine(kind, params.config, params.workers)
    if params.engine == "ray":
        from superlane_tools.commands.batch._ray_log import RAY_LOG_FILE
        from superlane_tools.commands.batch.ray_engine import RayEngine

        log = params.root / RAY_LOG_FILE
        return RayEngine(kind, params.config, params.workers, params.ray_address, log=log)
    raise UsageError(f"unknown engine {params.engine!r}: use one of {ENGINES}")
