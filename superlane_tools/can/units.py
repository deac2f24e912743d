"""Physical units of DBC signals: convert speeds and yaw rates to SI, refuse unknown units."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from superlane_tools.can.errors import CanError

SPEED_UNITS: dict[str, float] = {
    "m/s": 1.0,
    "mps": 1.0,
    "km/h": 1.0 / 3.6,
    "kph": 1.0 / 3.6,
    "kmh": 1.0 / 3.6,
    "kmph": 1.0 / 3.6,
    "mph": 0.44704,
}
"""Speed units seen in real DBCs and their factor to metres per second."""
YAW_RATE_UNITS: dict[str, float] = {
    "rad/s": 1.0,
    "rps": 1.0,
    "deg/s": math.pi / 180.0,
    "deg/sec": math.pi / 180.0,
    "degree/s": math.pi / 180.0,
    "degrees/s": math.pi / 180.0,
    "dps": math.pi / 180.0,
    "°/s": math.pi / 180.0,
}
"""Angular-rate units and their factor to radians per second."""
QUANTITIES: dict[str, tuple[dict[str, float], str]] = {
    "speed": (SPEED_UNITS, "m/s"),
    "yaw_rate": (YAW_RATE_UNITS, "rad/s"),
}


def si_factor(unit: str, quantity: str, signal: str = "") -> float:
    """Return the factor that converts ``unit`` to SI for ``quantity`` (``speed``, ``yaw_rate``).

    Units are matched case-insensitively, ignoring spaces (``"km/h"``, ``"KPH"``, ``"m/s"``).

    Args:
        unit: The unit string from the DBC (or the configuration's override).
        quantity: ``speed`` (to m/s) or ``yaw_rate`` (to rad/s).
        signal: Signal name for the error message.

    Raises:
        CanError: If the unit is empty or unknown for the quantity: a used signal must say its
            unit (set it in the configuration when the DBC does not).
    """
    table, target = QUANTITIES[quantity]
    key = unit.strip().lower().replace(" ", "")
    if key in table:
        return table[key]
    known = ", ".join(sorted(table))
    what = f"signal {signal!r}" if signal else "a signal"
    shown = repr(unit) if unit.strip() else "no unit"
    raise CanError(
        f"{what} used as {quantity.replace('_', ' ')} (to {target}) has {shown} in the DBC; "
        f"known units: {known} (set the unit in the configuration to override)"
    )


def to_si(
    values: NDArray[np.float64], unit: str, quantity: str, signal: str = ""
) -> NDArray[np.float64]:
    """Return ``values`` converted from ``unit`` to SI (see :func:`si_factor`).

    Raises:
        CanError: If the unit is empty or unknown for the quantity.
    """
    return np.asarray(values, dtype=np.float64) * si_factor(unit, quantity, signal)
