"""The paper's printed closed forms, transcribed verbatim (nothing here is derived).

Each function returns the equation as printed in Section 3 of the paper, with the paper's
symbols. Summed equations are given by their summand for a segment angle ``t`` (the printed
sums are sums of identical summands); the audit compares these with :mod:`derive.energy`.
"""

from __future__ import annotations

import sympy as sp

from . import symbols as S

#: Symbols the paper uses but never defines: ``l`` in Eq. (14), read here as L (it makes the
#: payload potential vanish for the straight actuator); x, y of the point Q; R_i in Eq. (5).
l_eq14, x_Q, y_Q, R_i = sp.symbols("l x y R_i", real=True)


def eq1(n, t) -> sp.Eq:
    """Eq. (1): L/n = l_i theta_i."""
    l_i = sp.Symbol("l_i", positive=True)
    return sp.Eq(S.L / n, l_i * t)


def eq5_summand(n, t) -> sp.Expr:
    """Eq. (5), right-hand side: -P r1^3 pi sum theta_i."""
    return -S.P * S.r1**3 * sp.pi * t


def eq5_middle_summand(n, t) -> sp.Expr:
    """Eq. (5), middle form: -P [sum pi r1^2 (R_i + r1) theta_i - pi r1^2 L], per segment."""
    return -S.P * (sp.pi * S.r1**2 * (R_i + S.r1) * t - sp.pi * S.r1**2 * S.L / n)


def eq8_summand(n, t) -> sp.Expr:
    """Eq. (8): theta_i^2 n E pi (5 r1^4 - 4 r2^2 (r1 + d)^2 - r2^4) / (8 L)."""
    return t**2 * n * S.E * sp.pi * (5 * S.r1**4 - 4 * S.r2**2 * (S.r1 + S.d) ** 2 - S.r2**4) / (8 * S.L)


def eq10(n, t) -> sp.Expr:
    """Eq. (10): Delta r_2i = sqrt((L r2^2 + n r1^3 theta_i)/(L + n d theta_i + n r1 theta_i)) - r2."""
    return sp.sqrt((S.L * S.r2**2 + n * S.r1**3 * t) / (S.L + n * S.d * t + n * S.r1 * t)) - S.r2


def eq11() -> sp.Expr:
    """Eq. (11): r_1d = sqrt(r1^2 - d^2 sin^2 omega) + d cos omega."""
    return sp.sqrt(S.r1**2 - S.d**2 * sp.sin(S.omega) ** 2) + S.d * sp.cos(S.omega)


def eq13_summand(n, t) -> sp.Expr:
    """Eq. (13): E pi (L + r1 theta_i)(r1 + r2) / (2 n (r1 - r2)) * (sqrt(...) - r2)^2."""
    return S.E * sp.pi * (S.L + S.r1 * t) * (S.r1 + S.r2) / (2 * n * (S.r1 - S.r2)) * eq10(n, t) ** 2


def eq14(F, Omega) -> sp.Expr:
    """Eq. (14): psi_pyl = y F sin(Omega) + (l - x) F cos(Omega)."""
    return y_Q * F * sp.sin(Omega) + (l_eq14 - x_Q) * F * sp.cos(Omega)


def eq15(xs: list[sp.Expr]) -> sp.Expr:
    """Eq. (15): psi_grvty = M g L / 2 - (M g / n) sum x_i, x_i the segment mid-points."""
    n = len(xs)
    return S.M * S.g * S.L / 2 - S.M * S.g / n * sum(xs)


def eq16_width() -> sp.Expr:
    """Eq. (16): 2 N eta_r = 2 pi r2 (L + r1 theta_TOL) P, i.e. the width 2 pi r2."""
    return 2 * sp.pi * S.r2


def eq18(theta_tol) -> sp.Expr:
    """Eq. (18): psi_fbrs = 4 P pi^2 r1^2 r2 theta_TOL tan^2 rho."""
    return 4 * S.P * sp.pi**2 * S.r1**2 * S.r2 * theta_tol * sp.tan(S.rho) ** 2


def hat_omega_printed(w: sp.Matrix) -> sp.Matrix:
    """Appendix (a), the printed hat map of omega: [[0, -w1, w2], [w3, 0, -w1], [-w2, w1, 0]]."""
    return sp.Matrix([[0, -w[0], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def twist_printed(l_i) -> sp.Matrix:
    """Section 3.1: xi_i = [l_i 0 0 0 0 1]^T."""
    return sp.Matrix([l_i, 0, 0, 0, 0, 1])
