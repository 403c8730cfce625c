"""JSON that is valid JSON: no bare NaN or Infinity, a null with its reason beside it.

Python's :func:`json.dumps` writes ``NaN`` and ``Infinity``, which strict JSON parsers (and
``jq``) reject. :func:`dumps` writes every non-finite number as ``null`` and adds, in the object
that holds it, a key ``<key>_reason`` saying what the number was ("not a number", "infinite"),
unless the producer already put a reason there. NumPy scalars and arrays become plain numbers
and lists. Results should carry their own ``None`` and reason where they know why a value is
missing; this is the safety net that keeps the output parseable whatever slips through.

Examples
--------
>>> print(dumps({"exponent": float("nan"), "tip": [1.0, float("inf")]}, sort_keys=True))
{"exponent": null, "exponent_reason": "not a number", "tip": [1.0, null], "tip_reason": "element 1 is infinite"}
>>> print(dumps({"k": None, "k_reason": "needs two points"}))
{"k": null, "k_reason": "needs two points"}
"""

from __future__ import annotations

import json
import math
import sys
from typing import Any

__all__ = ["clean", "dumps"]


def _why(value: float) -> str:
    return "not a number" if math.isnan(value) else "infinite"


def _plain(value: Any) -> Any:
    np = sys.modules.get("numpy")  # no NumPy loaded, no NumPy values: the command line starts without it
    if np is None:
        return value
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _clean_list(items: list | tuple, path: str) -> tuple[list, str]:
    """The cleaned list and a reason naming its first non-finite element ("" when none)."""
    out, reason = [], ""
    for i, item in enumerate(items):
        item = _plain(item)
        if isinstance(item, float) and not math.isfinite(item):
            reason = reason or f"element {path}{i} is {_why(item)}"
            out.append(None)
        elif isinstance(item, (list, tuple)):
            sub, why = _clean_list(item, f"{path}{i}.")
            reason = reason or why
            out.append(sub)
        else:
            out.append(clean(item))
    return out, reason


def clean(data: Any) -> Any:
    """A copy of ``data`` with every non-finite float replaced by None (reasons beside, see module)."""
    data = _plain(data)
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        out: dict = {}
        reasons: dict = {}
        for key, value in data.items():
            value = _plain(value)
            if isinstance(value, float) and not math.isfinite(value):
                out[key] = None
                reasons[f"{key}_reason"] = _why(value)
            elif isinstance(value, (list, tuple)):
                out[key], why = _clean_list(value, "")
                if why:
                    reasons[f"{key}_reason"] = why
            else:
                out[key] = clean(value)
        for key, why in reasons.items():
            out.setdefault(key, why)
        return out
    if isinstance(data, (list, tuple)):
        return _clean_list(data, "")[0]
    return data


def dumps(data: Any, **kwargs: Any) -> str:
    """:func:`json.dumps` of :func:`clean` (``data``), refusing NaN and Infinity outright."""
    return json.dumps(clean(data), allow_nan=False, **kwargs)
