"""Each term of the total potential energy, Eq. (3), derived from its integrand or definition.

Nothing here is typed in from the paper's closed forms: the integrals of Eq. (6)-(7) and
(11)-(13) are integrated, Eq. (9) is solved, the fibre force balance of Eq. (16) is solved, and
the payload and gravity potentials are built from force vectors and the points they act on. The
paper's printed closed forms live in :mod:`derive.paper`; :mod:`derive.audit` compares the two.

The summed terms of Eq. (5), (8), (13) and (18) are sums of one expression per segment, so the
derivations return the *summand* for a generic segment angle ``t`` and segment count ``n``
(``n`` may be a SymPy symbol, for the audit, or an int, for code generation).

Variants
--------
``paper``   Eq. (13) as derived from its own integrand, factor (L + n r1 theta_i); the fibre force
            balance Eq. (16) on the projected chamber width 2 r2 (one pi in Eq. 18). These
            reproduce the paper's Table 2.
``printed`` Eq. (13) exactly as printed, factor (L + r1 theta_i); Eq. (16) as printed, on the
            chamber circumference 2 pi r2 (pi^2 in Eq. 18, which follows from Eq. 16 as printed).
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from . import symbols as S
from .effects import check_variant

#: A symbolic segment count, for derivations that hold for every n.
n_sym = sp.Symbol("n", positive=True, integer=True)
#: The radius change of the chamber of one segment, Eq. (9)-(10).
Delta_r2 = sp.Symbol("Delta_r2", real=True)
#: The radial tension of one fibre, Eq. (16).
eta_r = sp.Symbol("eta_r", real=True)
#: The total bending angle theta_TOL, Eq. (17).
theta_TOL = sp.Symbol("theta_TOL", real=True)


# ---------------------------------------------------------------------------------------------
# Eq. (5): compressed air


def segment_volume(radius: sp.Expr, axis_offset: sp.Expr, t: sp.Expr, n) -> sp.Expr:
    """Volume of a bent cylinder segment: a disc of ``radius`` whose centre lies ``axis_offset``
    beyond the inextensible layer, swept by ``t`` about the bending axis at radius L/(n t).

    Integrated over the disc in polar coordinates (r, phi): each area element travels
    (R + axis_offset - r cos phi) t, with R = L/(n t) (Eq. 1).
    """
    r, phi = sp.symbols("r phi", positive=True)
    R = S.L / (n * t)
    inner = sp.integrate((R + axis_offset - r * sp.cos(phi)) * t * r, (phi, 0, 2 * sp.pi))
    return sp.simplify(sp.integrate(inner, (r, 0, radius)))


@lru_cache(maxsize=None)
def air(n=n_sym, t=S.t) -> sp.Expr:
    """Eq. (5) summand: -P dV_i for one segment.

    The rubber is incompressible (Section 3.2.1), so the chamber's volume change equals that of
    the whole segment: the r1-cylinder whose axis lies r1 from the inextensible layer, bent by t,
    minus its straight volume pi r1^2 L/n.
    """
    dV = segment_volume(S.r1, S.r1, t, n) - sp.pi * S.r1**2 * S.L / n
    return sp.simplify(-S.P * dV)


# ---------------------------------------------------------------------------------------------
# Eq. (6)-(8): axial rubber


@lru_cache(maxsize=None)
def axial_parts(n=n_sym, t=S.t) -> tuple[sp.Expr, sp.Expr]:
    """The two integrals of Eq. (8) for one segment: solid cylinder (Eq. 6) and chamber (Eq. 7).

    Strip elements of the cross-section (Fig. 3a): the solid's strip at angle alpha has area
    dS = 2 r1^2 sin^2(alpha) d(alpha) (Appendix b) and stretches by r1 (1 - cos alpha) t; the
    chamber's strip at angle beta has area 2 r2^2 sin^2(beta) d(beta) and stretches by
    (r1 + d - r2 cos beta) t. Each stores n E lambda^2 / (2 L) dS (a bar of length L/n).
    """
    a, b = S.alpha, S.beta
    lam_sld = S.r1 * (1 - sp.cos(a)) * t
    dS_sld = 2 * S.r1**2 * sp.sin(a) ** 2
    lam_cmb = (S.r1 + S.d - S.r2 * sp.cos(b)) * t
    dS_cmb = 2 * S.r2**2 * sp.sin(b) ** 2
    psi_sld = sp.integrate(sp.expand(n * S.E * lam_sld**2 / (2 * S.L) * dS_sld), (a, 0, sp.pi))
    psi_cmb = sp.integrate(sp.expand(n * S.E * lam_cmb**2 / (2 * S.L) * dS_cmb), (b, 0, sp.pi))
    return sp.factor(psi_sld), sp.factor(psi_cmb)


@lru_cache(maxsize=None)
def axial(n=n_sym, t=S.t) -> sp.Expr:
    """Eq. (8) summand: the solid cylinder's axial energy minus the chamber's."""
    sld, cmb = axial_parts(n, t)
    return sp.factor(sld - cmb)


# ---------------------------------------------------------------------------------------------
# Eq. (9)-(13): radial rubber


def volume_conservation(n=n_sym, t=S.t) -> sp.Eq:
    """Eq. (9): the rubber volume of a segment before and after bending.

    After bending, the segment is the r1-cylinder bent by t (centre r1 from the layer) minus
    the expanded chamber of radius r2 + Delta_r2 (centre r1 + d from the layer); the volumes
    follow from :func:`segment_volume` (Pappus' theorem).
    """
    before = sp.pi * S.L / n * (S.r1**2 - S.r2**2)
    after = segment_volume(S.r1, S.r1, t, n) - segment_volume(S.r2 + Delta_r2, S.r1 + S.d, t, n)
    return sp.Eq(before, sp.expand(after))


@lru_cache(maxsize=None)
def expanded_radius_squared(n=n_sym, t=S.t) -> sp.Expr:
    """Eq. (9) solved for (r2 + Delta_r2)^2, the quantity it is linear in."""
    eq = volume_conservation(n, t)
    q = sp.Symbol("q", positive=True)
    sq = sp.solve(eq.subs(Delta_r2, sp.sqrt(q) - S.r2), q)
    assert len(sq) == 1, sq
    return sp.factor(sq[0])


@lru_cache(maxsize=None)
def delta_r2(n=n_sym, t=S.t) -> sp.Expr:
    """Eq. (10): the positive root of Eq. (9), minus r2."""
    return sp.sqrt(expanded_radius_squared(n, t)) - S.r2


def r1d() -> sp.Expr:
    """Eq. (11): distance from the chamber centre to the outer surface at angle omega.

    Cosine law in the triangle (d, r1d, r1) with omega the angle between d and r1d:
    r1^2 = d^2 + r1d^2 - 2 d r1d cos(omega); the positive root (r1 > d).
    """
    x = sp.Symbol("x", positive=True)
    roots = sp.solve(sp.Eq(S.r1**2, S.d**2 + x**2 - 2 * S.d * x * sp.cos(S.omega)), x)
    # keep the root that is positive for every omega: d cos(omega) + sqrt(...)
    good = [r for r in roots if sp.simplify(r.subs(S.omega, sp.pi / 2) - sp.sqrt(S.r1**2 - S.d**2)) == 0]
    assert len(good) == 1, roots
    return sp.simplify(good[0])


def cos_sqrt_integrand() -> sp.Expr:
    """The integrand that vanishes in Eq. (13): cos(omega) sqrt(r1^2 - d^2 sin^2(omega))."""
    return sp.cos(S.omega) * sp.sqrt(S.r1**2 - S.d**2 * sp.sin(S.omega) ** 2)


def cos_sqrt_integral_vanishes() -> bool:
    """Prove  int_0^{2 pi} cos(w) sqrt(r1^2 - d^2 sin^2 w) dw = 0  by symmetry.

    With f(w) the integrand: f(pi - w) = -f(w), so the integral over [0, pi] equals its own
    negative (substitute w -> pi - w) and is 0; and f(2 pi - w) = f(w), so the integral over
    [pi, 2 pi] equals that over [0, pi]. SymPy checks both identities.
    """
    f = cos_sqrt_integrand()
    w = S.omega
    odd_about_half_pi = sp.simplify(f.subs(w, sp.pi - w) + f) == 0
    even_about_pi = sp.simplify(f.subs(w, 2 * sp.pi - w) - f) == 0
    return bool(odd_about_half_pi and even_about_pi)


@lru_cache(maxsize=None)
def r1d_squared_integral() -> sp.Expr:
    """int_0^{2 pi} r1d^2 d(omega), with the cos*sqrt part set to 0 by the symmetry lemma."""
    expanded = sp.expand(r1d() ** 2)
    f = cos_sqrt_integrand()
    coeff = sp.simplify(expanded.coeff(sp.sqrt(S.r1**2 - S.d**2 * sp.sin(S.omega) ** 2)) / sp.cos(S.omega))
    rest = sp.simplify(expanded - coeff * f)
    assert not rest.has(sp.sqrt(S.r1**2 - S.d**2 * sp.sin(S.omega) ** 2)), rest
    assert cos_sqrt_integral_vanishes()
    return sp.simplify(sp.integrate(rest, (S.omega, 0, 2 * sp.pi)))


@lru_cache(maxsize=None)
def radial(n=n_sym, t=S.t) -> sp.Expr:
    """Eq. (13) summand, derived from its integrand (Eq. 11-12).

    U_r,i = int_0^{2 pi} E r_intl eps^2 / 2 dS_sctr  with  r_intl = r1d - r2,
    eps = Delta_r2 / (r1 - r2),  dS_sctr = (r1d + r2)/2 (L/n + r1 t) d(omega).
    The integrand is E eps^2 (L/n + r1 t) (r1d^2 - r2^2) / 4, so only the integral of r1d^2
    is needed (:func:`r1d_squared_integral`).
    """
    integral = r1d_squared_integral() - 2 * sp.pi * S.r2**2
    # everything but Delta_r2^2, simplified on its own so that Eq. (10) stays recognisable
    coeff = sp.factor(sp.simplify(S.E / (S.r1 - S.r2) ** 2 * (S.L / n + S.r1 * t) / 4 * integral))
    return coeff * delta_r2(n, t) ** 2


def radial_factor_ratio(n=n_sym, t=S.t) -> sp.Expr:
    """Derived Eq. (13) summand over the printed one: (L + n r1 t)/(L + r1 t)."""
    from . import paper

    return sp.simplify(radial(n, t) / paper.eq13_summand(n, t))


# ---------------------------------------------------------------------------------------------
# Eq. (16)-(18): fibres


def fibre_width(variant: str) -> sp.Expr:
    """The chamber width the radial expansion force acts on in Eq. (16).

    ``printed``: the circumference 2 pi r2, as Eq. (16) prints it. ``paper``: the projected
    width 2 r2 (the force a pressure exerts on a half-cylinder across its diametral plane),
    which is what reproduces the paper's Table 2.
    """
    check_variant(variant)
    return 2 * sp.pi * S.r2 if variant == "printed" else 2 * S.r2


def fibre_balance(variant: str = "paper") -> sp.Eq:
    """Eq. (16): 2 N eta_r = w (L + r1 theta_TOL) P, with N = (L + r1 theta_TOL)/(2 pi r1 tan rho)
    turns per fibre and w the chamber width (:func:`fibre_width`)."""
    N = (S.L + S.r1 * theta_TOL) / (2 * sp.pi * S.r1 * sp.tan(S.rho))
    return sp.Eq(2 * N * eta_r, fibre_width(variant) * (S.L + S.r1 * theta_TOL) * S.P)


@lru_cache(maxsize=None)
def fibre_tension(variant: str = "paper") -> sp.Expr:
    """Eq. (16) solved for the radial fibre tension eta_r."""
    return sp.solve(fibre_balance(variant), eta_r)[0]


@lru_cache(maxsize=None)
def fibres_total(variant: str = "paper") -> sp.Expr:
    """Eq. (18): psi_fbrs as a function of theta_TOL, from the force balance of Eq. (16).

    2 eta_a = 2 eta_r tan(rho) (:func:`fibre_tension`); the axial displacement is r1 theta_TOL,
    so psi_fbrs = 2 eta_a r1 theta_TOL.
    """
    ea = fibre_tension(variant) * sp.tan(S.rho)
    return sp.simplify(2 * ea * S.r1 * theta_TOL)


@lru_cache(maxsize=None)
def fibres(variant: str = "paper", t=S.t) -> sp.Expr:
    """Eq. (18) per segment: psi_fbrs is linear in theta_TOL = sum theta_i (Eq. 17)."""
    total = fibres_total(variant)
    coeff = sp.simplify(total / theta_TOL)
    assert not coeff.has(theta_TOL)
    return coeff * t


# ---------------------------------------------------------------------------------------------
# Eq. (14)-(15): payload and gravity


def force_vector(F: sp.Expr, Omega: sp.Expr) -> sp.Matrix:
    """A force of magnitude F at angle Omega from the vertical (x, downward), turned toward -y.

    Omega = 0: along +x (downward, like gravity); Omega = 90 deg: along -y, horizontal and
    against the bending direction, as in Fig. 2 and Table 2.
    """
    return sp.Matrix([F * sp.cos(Omega), -F * sp.sin(Omega)])


def point_potential(force: sp.Matrix, point: sp.Matrix, rest_point: sp.Matrix) -> sp.Expr:
    """Potential of a constant force acting at a moving point: -f . (p - p_rest)."""
    return -(force.T * (point - rest_point))[0]


def payload_tip(thetas: list[sp.Expr], F: sp.Expr, Omega: sp.Expr) -> sp.Expr:
    """Eq. (14) derived: the potential of a tip payload from the POE end point (Eq. 2)."""
    from .kinematics import poe

    g = poe(thetas)
    return point_potential(force_vector(F, Omega), g[:2, 3], sp.Matrix([S.L, 0]))


def gravity_midpoints(thetas: list[sp.Expr]) -> sp.Expr:
    """Eq. (15) derived: each segment's weight M g / n at its mid-point, as the paper places it.

    The mid-point of segment i is the POE of joints 1..i with theta_i replaced by theta_i / 2.
    """
    from .kinematics import poe

    n = len(thetas)
    weight = sp.Matrix([S.M * S.g / n, 0])
    total = sp.Integer(0)
    for i in range(1, n + 1):
        mid = poe(thetas[:i], n=n, last_fraction=sp.Rational(1, 2))[:2, 3]
        rest = sp.Matrix([(i - sp.Rational(1, 2)) * S.L / n, 0])
        total += point_potential(weight, mid, rest)
    return total


# ---------------------------------------------------------------------------------------------
# Per-segment templates used by code generation


def separable(effects_names: tuple[str, ...], n: int, variant: str, t=S.t) -> dict[str, sp.Expr]:
    """The per-segment summands of the separable terms (air, axial, radial, fibres) for ``n``."""
    from . import paper

    check_variant(variant)
    out: dict[str, sp.Expr] = {}
    if "air" in effects_names:
        out["air"] = air(n_sym, t).subs(n_sym, n)
    if "axial" in effects_names:
        out["axial"] = axial(n_sym, t).subs(n_sym, n)
    if "radial" in effects_names:
        expr = radial(n_sym, t) if variant == "paper" else paper.eq13_summand(n_sym, t)
        out["radial"] = expr.subs(n_sym, n)
    if "fibres" in effects_names:
        out["fibres"] = fibres(variant, t)
    return out
