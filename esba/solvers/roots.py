"""Brent's method for a root of a scalar function on a bracket (the algorithm of SciPy's ``brentq``).

Path following locates every value and eigenvalue crossing with it. SciPy's own ``brentq`` lives in
``scipy.optimize``, whose import alone took 0.3 s of the 0.7 s of an ``esba path`` run; this is the
same algorithm (Brent 1973, as in SciPy's ``zeros.c``: inverse quadratic interpolation or the
secant, bisection when they do not shrink the bracket fast enough), with the same tolerances.

Examples
--------
>>> root = brentq(lambda x: x * x - 2.0, 0.0, 2.0, xtol=1e-15, rtol=1e-15)
>>> abs(root - 2.0 ** 0.5) < 1e-15
True
"""

from __future__ import annotations

from typing import Callable

__all__ = ["brentq"]

#: SciPy's default relative tolerance: four times the double precision's epsilon.
RTOL = 4 * 2.220446049250313e-16


def brentq(f: Callable[[float], float], a: float, b: float, xtol: float = 2e-12, rtol: float = RTOL, maxiter: int = 100) -> float:
    """A root of ``f`` in [a, b], where f(a) and f(b) have opposite signs (or one is 0).

    The answer is within ``xtol + rtol * |root|`` of a root (to the function's own accuracy).

    Raises
    ------
    ValueError
        f(a) and f(b) have the same sign, or a tolerance is not positive.
    RuntimeError
        no convergence in ``maxiter`` iterations.
    """
    if xtol <= 0 or rtol < RTOL:
        raise ValueError(f"brentq: xtol must be > 0 and rtol >= {RTOL:.3g} (got xtol = {xtol}, rtol = {rtol})")
    xpre, xcur = float(a), float(b)
    fpre, fcur = float(f(xpre)), float(f(xcur))
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if (fpre > 0) == (fcur > 0):
        raise ValueError("brentq: f(a) and f(b) must have opposite signs")
    xblk = fblk = spre = scur = 0.0
    for _ in range(maxiter):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0) != (fcur < 0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # the secant
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # inverse quadratic interpolation
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry  # the interpolation is good: take it
            else:
                spre, scur = sbis, sbis  # it is not: bisect
        else:
            spre, scur = sbis, sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = float(f(xcur))
    raise RuntimeError(f"brentq: no convergence in {maxiter} iterations")
