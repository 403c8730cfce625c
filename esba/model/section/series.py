"""The torsion of the eccentric annulus by a series (exact to round-off): the cross-check of the finite elements."""

from __future__ import annotations

import math

from esba.infra import checks
from esba.infra.threads import blas_one_thread

from .geometry import SectionError, SeriesError, check_geometry

__all__ = ["SERIES_TERMS", "series_torsion"]

#: Terms of :func:`series_torsion`: J to round-off down to walls of 0.5 mm at r1 = 8 (r2 = 1, d = 6.5).
SERIES_TERMS = 160


def series_torsion(r1: float, r2: float, d: float, *, terms: int = SERIES_TERMS) -> tuple[float, float]:
    """(J, C): the torsion constant and the chamber's stress-function value by a series, exact to
    round-off once converged (the cross-check of the finite elements; a few milliseconds).

    Prandtl's phi = -|w|²/2 + Re F(w) with w = y + r1 + i z (the disc's centre at 0, the chamber's
    at c = -d) and F = sum_k a_k (w/r1)^k + sum_k b_k (r2/(w - c))^k: analytic in the disc plus
    analytic outside the chamber, which spans every harmonic function of the annulus but the
    logarithm ln|w - c|, whose coefficient the chamber's circulation condition sets to zero. The
    real coefficients (the section is symmetric) and C are fitted by least squares to phi = 0 on
    the outer circle and phi = C on the chamber's; then J = 2 ∫phi dA + 2 C pi r2², with ∫phi dA
    by Green's identity (q = |w|²/4, ∇²q = 1) as integrals over the two circles, by the
    trapezoidal rule (spectrally accurate for these periodic integrands).

    Raises
    ------
    SeriesError
        When the series does not fit the boundary values to 1e-9 r1² (too few terms for a wall
        this thin): more ``terms`` are needed.

    Examples
    --------
    >>> J, C = series_torsion(8.0, 3.0, 0.0, terms=4)
    >>> round(float(J) / (math.pi * (8**4 - 3**4) / 2), 12), round(C, 9)
    (1.0, 27.5)
    """
    import numpy as np

    r1, r2, d = check_geometry(r1, r2, d)
    K = checks.whole("terms", terms, 1, SectionError, high=1000, why="the fit's matrix grows as terms²")
    M = 4 * K + 16
    c = -d
    t = 2 * np.pi * np.arange(M) / M
    outer, inner = r1 * np.exp(1j * t), c + r2 * np.exp(1j * t)
    k = np.arange(K + 1)

    def columns(w):
        return (w[:, None] / r1) ** k[None, :], (r2 / (w[:, None] - c)) ** k[None, 1:]

    (ao, bo), (ai, bi) = columns(outer), columns(inner)
    G = np.vstack([np.hstack([ao.real, bo.real, np.zeros((M, 1))]), np.hstack([ai.real, bi.real, -np.ones((M, 1))])])
    rhs = np.concatenate([np.full(M, r1**2 / 2), np.abs(inner) ** 2 / 2])
    with blas_one_thread():  # a small dense problem: BLAS threads only wait on a busy machine
        coef = np.linalg.lstsq(G, rhs, rcond=None)[0]
    misfit = float(np.max(np.abs(G @ coef - rhs)))
    if not misfit < 1e-9 * r1**2:
        raise SeriesError(f"the series of {K} terms did not fit the boundary values (misfit {misfit:.2g} mm²): give more terms")
    a, b, C = coef[: K + 1], coef[K + 1 : -1], coef[-1]

    def dF(w):
        da = ((k[1:] / r1) * (w[:, None] / r1) ** (k[1:] - 1)) @ a[1:]
        db = (-(k[1:] / (w[:, None] - c)) * (r2 / (w[:, None] - c)) ** k[1:]) @ b
        return da + db

    def green(w, n, ds, phi):  # ∮ (phi dq/dn - q dphi/dn) ds
        dq = (w * np.conj(n)).real / 2
        dphi = -(w * np.conj(n)).real + (dF(w) * n).real
        return float(np.sum((phi * dq - np.abs(w) ** 2 / 4 * dphi) * ds))

    q_area = (math.pi * r1**4 / 2 - math.pi * r2**4 / 2 - math.pi * r2**2 * d**2) / 4  # ∫ q dA
    # n out of the silicone: outward on the outer circle, into the chamber on the inner one
    phi_area = green(outer, np.exp(1j * t), 2 * np.pi * r1 / M, 0.0) + green(inner, -np.exp(1j * t), 2 * np.pi * r2 / M, C) - 2 * q_area
    return float(2 * phi_area + 2 * C * math.pi * r2**2), float(C)
