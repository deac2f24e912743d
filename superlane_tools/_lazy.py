"""Lazy package attributes: a package names where each export lives, imported on first use.

``lanes``, ``commands.reprocess`` and ``commands.camera_estimate`` keep ``import`` of the package
cheap (``slt --help``, the kernel compiler started before the pipeline's imports) this way::

    __getattr__ = lazy_attributes(__name__, globals(), {"fit_frame": "superlane_tools.lanes..."})
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, MutableMapping
from typing import Any


def lazy_attributes(
    package: str, namespace: MutableMapping[str, Any], homes: Mapping[str, str]
) -> Callable[[str], Any]:
    """Return a module ``__getattr__`` importing ``name`` from ``homes[name]`` once.

    The value is stored in ``namespace`` (the package's globals), so later lookups do not come
    back here.
    """

    def __getattr__(name: str) -> Any:  # noqa: N807 - the module hook's name
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home), name)
        namespace[name] = value
        return value

    return __getattr__
