"""Input checks shared by every validated dataclass of esba.

Each check names the field, the value and what is allowed, and raises the caller's own error
class (``SceneError``, ``SolverOptionsError``, ...), so a message reads the same everywhere.

Examples
--------
>>> whole("segments", 3, 1)
3
>>> whole("segments", 0, 1)
Traceback (most recent call last):
...
ValueError: segments=0: expected a whole number >= 1
>>> finite("pressure", float("nan"))
Traceback (most recent call last):
...
ValueError: pressure=nan: expected a finite number
"""

from __future__ import annotations

import math
from numbers import Integral
from typing import Any


def whole(name: str, value: Any, low: int, error: type[Exception] = ValueError) -> int:
    """``value`` as an int if it is a whole number (not a bool) >= ``low``."""
    if isinstance(value, bool) or not isinstance(value, Integral) or value < low:
        raise error(f"{name}={value!r}: expected a whole number >= {low}")
    return int(value)


def finite(name: str, value: Any, error: type[Exception] = ValueError) -> float:
    """``value`` as a float if it is a finite real number (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise error(f"{name}={value!r}: expected a finite number")
    return float(value)
