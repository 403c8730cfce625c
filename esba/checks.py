"""Value checks shared by esba: inputs of every validated dataclass, and JSON-ready outputs.

Each check names the field, the value and what is allowed, and raises the caller's own error
class (``SceneError``, ``SolverOptionsError``, ...), so a message reads the same everywhere.
:func:`json_ready` turns results into what JSON can hold: no NaN or infinity (None instead).

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
>>> json_ready({"a": [1.0, float("nan")], "b": np.float64(2.0)})
{'a': [1.0, None], 'b': 2.0}
"""

from __future__ import annotations

import math
from numbers import Integral
from typing import Any

import numpy as np


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


def json_ready(value: Any) -> Any:
    """``value`` with non-finite floats as None and NumPy scalars and arrays as Python ones, recursively."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value
