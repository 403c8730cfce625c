"""Numbers that may be round-off, printed without their noise digits.

A relative difference of two computations of the same thing (a closed form against a trace, PSO
against IPOPT), or the ratio of a round-off eigenvalue to a real one, is noise below some floor: its
digits change with the BLAS kernel, the thread count and the compiler, so a page or a message that
printed them would differ from machine to machine. :func:`floored` prints such a number as it is
above its floor and as ``< floor`` below it (``within ±floor`` for a signed difference; the floor is
printed, so the reader knows what it is).

Examples
--------
>>> floored(3.3e-16, ".1e", 1e-15), floored(0.0, ".1e", 1e-15), floored(2.5e-3, ".1e", 1e-15)
('< 1e-15', '< 1e-15', '2.5e-03')
>>> floored(-7.0e-10, "+.2e", 1e-8), floored(-2.07e-3, "+.2e", 1e-8)
('within ±1e-08', '-2.07e-03')
"""

from __future__ import annotations

import math

__all__ = ["floored", "RELATIVE_FLOOR", "ROUNDOFF_RATIO"]

#: Relative differences of two double-precision computations below this are round-off (a few ulps
#: of 2.2e-16).
RELATIVE_FLOOR = 1e-15
#: Ratios of eigenvalues (of a Fisher matrix, say) below this are round-off: an eigenvalue is known
#: to about 1e-16 times the largest, and the products that form the matrix lose a few digits more.
ROUNDOFF_RATIO = 1e-12


def floored(value: float, spec: str, floor: float) -> str:
    """``format(value, spec)``, or ``< floor`` where ``|value| < floor`` (``within ±floor`` for a
    signed ``spec``: the sign of noise is noise too)."""
    if math.isfinite(value) and abs(value) < floor:
        return f"within ±{floor:.0e}" if spec.startswith(("+", " ")) else f"< {floor:.0e}"
    return format(value, spec)
