"""Value checks shared by esba: inputs of every validated dataclass and entry point, and JSON-ready outputs.

Each check names the field, the value and what is allowed, and raises the caller's own error
class (``SceneError``, ``SolverOptionsError``, ...), so a message reads the same everywhere.
Counts that decide how much time or memory a run takes have an upper bound, and the message
says why.

Examples
--------
>>> whole("segments", 3, 1)
3
>>> whole("segments", 0, 1)
Traceback (most recent call last):
...
ValueError: segments=0: expected a whole number >= 1
>>> whole("max_iter", 2**31, 1, high=100_000, why="an equilibrium takes tens")
Traceback (most recent call last):
...
ValueError: max_iter=2147483648: expected a whole number from 1 to 100000 (an equilibrium takes tens)
>>> finite("pressure", float("nan"))
Traceback (most recent call last):
...
ValueError: pressure=nan: expected a finite number
>>> number("--pressure", "0_1")
Traceback (most recent call last):
...
ValueError: --pressure '0_1': not a number (expected decimal digits such as 0.1 or 2e-3)
"""

from __future__ import annotations

import math
import re
import sys
from numbers import Integral
from typing import Any

#: The largest segment count esba builds a model for. The model's Hessian has n^2 entries and its
#: generation takes minutes beyond this; the accuracy benchmark's finest reference is n = 256, and the
#: tip is within 0.1 mm of it from n = 16 (docs/accuracy-vs-time.md).
MAX_SEGMENTS = 256
MAX_SEGMENTS_WHY = "the finest model of the accuracy benchmark; larger n costs n^2 memory and minutes to generate for no accuracy"

#: A decimal number as people write it (ASCII digits: no digit-group underscores, no hex, no
#: other scripts' digits, which Python's ``float()`` reads), or nan/inf, which
#: the field checks then refuse with their own message.
_NUMBER = re.compile(r"\s*[+-]?((\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?|nan|inf|infinity)\s*", re.IGNORECASE | re.ASCII)
_WHOLE = re.compile(r"\s*[+-]?\d+\s*", re.ASCII)


#: The longest value a message quotes whole; a longer one is cut and its length said (a 10 MB
#: string in a file must not come back as a 10 MB line).
QUOTE_LIMIT = 60


def quote(value: Any, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` for a message, cut to about ``limit`` characters.

    >>> quote("abc")
    "'abc'"
    >>> quote("x" * 1000)
    "'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx'... (1000 characters)"
    """
    text = repr(value)
    if len(text) <= limit:
        return text
    size = f" ({len(value)} characters)" if isinstance(value, str) else f" ({len(text)} characters)"
    return text[:limit] + ("'" if text[:1] in "'\"" else "") + "..." + size


def some(names: Any, shown: int = 5, width: int = 40) -> str:
    """The first ``shown`` of ``names``, each cut to ``width`` characters, and how many more.

    >>> some(["a", "b"])
    'a, b'
    >>> some([f"k{i}" for i in range(1000)])
    'k0, k1, k2, k3, k4 and 995 more'
    """
    names = [str(n) for n in names]
    head = [n if len(n) <= width else n[:width] + "..." for n in names[:shown]]
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    return ", ".join(head) + more


def whole(name: str, value: Any, low: int, error: type[Exception] = ValueError, high: int | None = None, why: str = "") -> int:
    """``value`` as an int if it is a whole number (not a bool) from ``low`` to ``high``."""
    bad = isinstance(value, bool) or not isinstance(value, Integral) or value < low or (high is not None and value > high)
    if bad:
        allowed = f">= {low}" if high is None else f"from {low} to {high}"
        raise error(f"{name}={quote(value)}: expected a whole number {allowed}" + (f" ({why})" if why else ""))
    return int(value)


def finite(name: str, value: Any, error: type[Exception] = ValueError) -> float:
    """``value`` as a float if it is a finite real number (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise error(f"{name}={quote(value)}: expected a finite number")
    return float(value)


def segments(value: Any, error: type[Exception] = ValueError, name: str = "segments") -> int:
    """A segment count: a whole number from 1 to :data:`MAX_SEGMENTS` (whole floats such as 3.0 pass)."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    return whole(name, value, 1, error, high=MAX_SEGMENTS, why=MAX_SEGMENTS_WHY)


def covariance(name: str, cov: Any, size: int | None = None, error: type[Exception] = ValueError) -> Any:
    """``cov`` as a float array if it is a covariance: square (``size`` x ``size`` when given),
    finite, symmetric and positive semi-definite (eigenvalues >= -1e-12 of the largest, round-off);
    else ``error`` naming ``name``.

    >>> covariance("cov", [[1.0, 0.0], [0.0, -1.0]])
    Traceback (most recent call last):
    ...
    ValueError: cov has a negative eigenvalue (-1): expected a positive semi-definite covariance (variances >= 0)
    """
    import numpy as np  # here: the command line's parser imports this module and no numerics

    try:
        a = np.asarray(cov, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise error(f"{name}={quote(cov)}: expected a square array of numbers (a covariance)") from None
    shape = f"{size} x {size}" if size else "square"
    if a.ndim != 2 or a.shape[0] != a.shape[1] or (size is not None and a.shape[0] != size) or a.size == 0:
        raise error(f"{name} has shape {a.shape}: expected a {shape} covariance")
    if not np.all(np.isfinite(a)):
        raise error(f"{name} holds a value that is not a finite number: expected a finite covariance")
    scale = float(np.max(np.abs(a)))
    if not np.allclose(a, a.T, rtol=1e-9, atol=1e-12 * scale):
        raise error(f"{name} is not symmetric: expected a covariance (cov[i, j] == cov[j, i])")
    low = float(np.min(np.linalg.eigvalsh(0.5 * (a + a.T))))
    if low < -1e-12 * max(scale, 1e-300):
        raise error(f"{name} has a negative eigenvalue ({low:.3g}): expected a positive semi-definite covariance (variances >= 0)")
    return 0.5 * (a + a.T)


def number(name: str, text: str, error: type[Exception] = ValueError, subnormal: bool = False) -> float:
    """The number a command-line word spells; Python's own ``float()`` also takes ``0_1`` (= 1).

    A subnormal number (``1e-320``, whose digits the double does not keep) is refused unless
    ``subnormal`` (a file esba wrote itself may hold any double)."""
    if not isinstance(text, str) or not _NUMBER.fullmatch(text):
        raise error(f"{name} {quote(text)}: not a number (expected decimal digits such as 0.1 or 2e-3)")
    value = float(text)
    if not subnormal and value != 0.0 and abs(value) < sys.float_info.min:  # subnormal: 1e-320 would come back as 9.99989e-321
        raise error(f"{name} {quote(text)}: below the smallest normal double ({sys.float_info.min:.3g}); give 0 or a larger number")
    return value


def whole_text(name: str, text: str, error: type[Exception] = ValueError) -> int:
    """The whole number a command-line word spells (no underscores, no signs other than -)."""
    if not isinstance(text, str) or not _WHOLE.fullmatch(text):
        raise error(f"{name} {quote(text)}: not a whole number (expected digits such as 3)")
    return int(text)
