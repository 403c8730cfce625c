"""Functions of a segment angle that stay exact at 0 in value, gradient and Hessian.

The bending radius l_i = L/(n theta_i) of Eq. (1) is infinite for a straight segment, so the
segment's chord (l_i sin theta_i, l_i (1 - cos theta_i)) is 0/0 there. Written with
``sinc(u) = sin(u)/u`` it is smooth, but ``sin(u)/u`` itself evaluates to NaN at 0 and loses
its second derivative to cancellation near 0 (``../shared/MEASUREMENTS.md``). So ``sinc`` is a
``Piecewise``: an alternating Taylor series for ``|u| < SINC_SWITCH`` and ``sin(u)/u`` beyond.
SymPy differentiates each branch, so gradient and Hessian inherit the same exactness; the
truncation error of the series at the switch is below 1e-17 in value and 3e-14 in the second
derivative.
"""

from __future__ import annotations

import sympy as sp

#: Where the series branch hands over to sin(u)/u.
SINC_SWITCH = sp.Rational(1, 10)


def sinc_series(u: sp.Expr) -> sp.Expr:
    """Taylor series of sin(u)/u to order u**8, in Horner form."""
    u2 = u**2
    return 1 - u2 / 6 * (1 - u2 / 20 * (1 - u2 / 42 * (1 - u2 / 72)))


def sinc(u: sp.Expr) -> sp.Expr:
    """``sin(u)/u`` as a Piecewise that is exact at u = 0 (value 1, u'' = -1/3).

    The generated code evaluates both branches (a CasADi ``if_else`` on SX does), and automatic
    differentiation in reverse mode multiplies the unused branch's partial derivatives by a zero
    seed: NaN where they are NaN, as those of ``sin(u)/u`` are at u = 0. So the quotient's argument
    is u + 1 inside the series branch and u itself wherever the quotient is used; its guard is
    spelled ``u**2 < SINC_SWITCH**2`` so that SymPy does not fold it into the outer condition.
    """
    w = u + sp.Piecewise((1, u**2 < SINC_SWITCH**2), (0, True))
    return sp.Piecewise((sinc_series(u), sp.Abs(u) < SINC_SWITCH), (sp.sin(w) / w, True))


def versinc(u: sp.Expr) -> sp.Expr:
    """``(1 - cos u)/u`` written as ``(u/2) sinc(u/2)**2``, exact at u = 0."""
    return u / 2 * sinc(u / 2) ** 2
