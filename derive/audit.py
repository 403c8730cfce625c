"""The paper's printed equations against their derivation: computed verdicts.

For each audited equation the printed form (:mod:`derive.paper`, transcribed verbatim) is set
against the form derived from first principles (:mod:`derive.energy`, :mod:`derive.kinematics`).
The verdict is computed, never typed in: the difference ``printed - derived`` is simplified;
if it is 0 the forms are ``identical``; if it is free of the configuration variables (the
segment angles, the tip coordinates) they are ``identical up to an additive constant`` (which
an energy may be: it does not move the equilibrium); otherwise they ``differ``, and the entry
keeps the simplified difference and the ratio ``derived / printed``.

Each entry also carries the intermediate steps of its derivation (the integrals of Eq. 6-7, Eq. 9
solved, the vanishing lemma of Eq. 13, the fibre force balance of Eq. 16, ...), each with the
computed check it rests on. The results tables are checked too (:func:`table_checks`: the rows of
Table 3 that must agree with each other, and with Table 2). :mod:`derive.audit_page` renders everything as
``docs/derivations.md``; ``esba audit`` writes it and ``esba audit --check`` fails when the
committed page is stale.

Examples
--------
>>> import sympy as sp
>>> t = sp.Symbol("t", real=True)
>>> compare(sp.sin(t) ** 2 + 1, 2 - sp.cos(t) ** 2, [t]).verdict
'identical'
>>> compare(t**2 + 3, t**2, [t]).verdict
'identical up to an additive constant'
>>> c = compare(2 * t, t, [t])
>>> c.verdict, c.difference, c.ratio
('differs', t, 1/2)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, Sequence

import sympy as sp

from . import energy as En
from . import kinematics as K
from . import paper
from . import symbols as S

IDENTICAL = "identical"
UP_TO_CONSTANT = "identical up to an additive constant"
DIFFERS = "differs"
#: The verdicts, from best to worst.
VERDICTS: tuple[str, ...] = (IDENTICAL, UP_TO_CONSTANT, DIFFERS)

#: Section 4.4.2: the pressure (MPa) the paper's analytical model needs to bend the Table 1
#: actuator to 90 degrees without payload.
PAPER_P_90DEG = 0.123

#: The paper's Table 1 actuator (mm, MPa, rad) with E = 0.54 MPa (Section 4.2), exact numbers.
TABLE_1 = {S.L: 135, S.r1: 8, S.r2: 3, S.d: 4, S.rho: sp.pi / 18, S.E: sp.Rational(54, 100)}

# Display symbols: the per-segment templates use a generic angle t; the page writes theta_i.
THETA_I = sp.Symbol("theta_i", real=True)
_THETA_TOTAL = sp.Symbol("Theta", real=True)
_F, _OMEGA = sp.Symbol("F", real=True), sp.Symbol("Omega", real=True)
_L_I = sp.Symbol("l_i", positive=True)  # the same symbol as paper.eq1's l_i
_PHI = sp.Symbol("phi", real=True)


# ---------------------------------------------------------------------------------------------
# Comparison


@dataclass(frozen=True)
class Comparison:
    """The computed outcome of setting a printed form against a derived one.

    Attributes
    ----------
    verdict : str
        one of :data:`VERDICTS`.
    difference : sympy object or None
        ``printed - derived``, simplified; None when identical.
    ratio : sympy.Expr or None
        ``derived / printed``, simplified, when the forms differ and are scalars; else None.
    """

    verdict: str
    difference: sp.Basic | None
    ratio: sp.Expr | None


def _residual(e: sp.Basic) -> sp.Basic:
    """An equation ``a = b`` as ``a - b``; anything else unchanged."""
    return e.lhs - e.rhs if isinstance(e, sp.Equality) else e


def _simplest(e: sp.Expr) -> sp.Expr:
    """``e`` simplified: 0 when it vanishes identically (trigonometric identities included)."""
    # expand_trig + expand settles the POE identities (Eq. 2, 15) at once; simplify the rest
    if e == 0 or sp.expand(sp.expand_trig(e)) == 0:
        return sp.Integer(0)
    s = sp.simplify(e)
    if s == 0 or sp.trigsimp(s) == 0:
        return sp.Integer(0)
    return s


def compare(printed: sp.Basic, derived: sp.Basic, variables: Iterable[sp.Symbol]) -> Comparison:
    """Compare a printed form with a derived one.

    Parameters
    ----------
    printed, derived : sympy Expr, Equality or Matrix
        the two forms (an equation ``a = b`` is compared through its residual ``a - b``, so
        both must be written with the same scaling). Matrices are identical or differ.
    variables : iterable of Symbol
        the configuration variables: a scalar difference free of them is an additive constant.

    Returns
    -------
    Comparison
    """
    p, q = _residual(printed), _residual(derived)
    if isinstance(p, sp.MatrixBase):
        diff = (p - q).applyfunc(_simplest)
        if diff.is_zero_matrix:
            return Comparison(IDENTICAL, None, None)
        return Comparison(DIFFERS, diff, None)
    diff = _simplest(p - q)
    if diff == 0:
        return Comparison(IDENTICAL, None, None)
    if not diff.free_symbols & set(variables):
        return Comparison(UP_TO_CONSTANT, diff, None)
    return Comparison(DIFFERS, diff, sp.factor(sp.simplify(q / p)))


def _worst(comparisons: Sequence[Comparison]) -> Comparison:
    """The comparison with the worst verdict (the first of those, for its difference)."""
    return max(comparisons, key=lambda c: VERDICTS.index(c.verdict))


# ---------------------------------------------------------------------------------------------
# Entries


@dataclass(frozen=True)
class Step:
    """One intermediate step of a derivation, shown on the page as ``lhs = rhs``.

    Attributes
    ----------
    title : str
    lhs : sympy object, str or None
        the left-hand side (a string is raw LaTeX, for a label); None shows ``rhs`` alone.
    rhs : sympy object
        the step's result.
    explanation : str
        what the step does, in plain words.
    check : bool or None
        the computed check the step rests on (None: the step only shows a result).
    """

    title: str
    lhs: sp.Basic | str | None
    rhs: sp.Basic
    explanation: str
    check: bool | None = None


@dataclass(frozen=True)
class AuditEntry:
    """Printed versus derived for one equation of the paper.

    Attributes
    ----------
    key : str
        the equation, e.g. ``"Eq. 13"``; the key of :func:`verdicts`.
    title : str
    printed, derived : sympy object
        the paper's form and the derived form (summands in the generic segment angle ``t``).
    verdict : str
        one of :data:`VERDICTS`, computed by :func:`compare`.
    difference : sympy object or None
        ``printed - derived``, simplified, unless identical.
    ratio : sympy.Expr or None
        ``derived / printed`` when the forms differ.
    explanation : str
        what the comparison means, in plain words (every discrepancy explained).
    checked_for : str
        the cases the verdict covers when it is proven case by case (e.g. ``n = 1, 2, 3, 4``).
    shown_for : str
        the case the printed and derived forms are shown for, when they depend on n.
    steps : tuple of Step
    """

    key: str
    title: str
    printed: sp.Basic
    derived: sp.Basic
    verdict: str
    difference: sp.Basic | None
    ratio: sp.Expr | None
    explanation: str
    checked_for: str = ""
    shown_for: str = ""
    steps: tuple[Step, ...] = ()


def _entry(
    key, title, printed, derived, comparison: Comparison, explanation, checked_for="", shown_for="", steps=()
) -> AuditEntry:
    return AuditEntry(
        key=key,
        title=title,
        printed=printed,
        derived=derived,
        verdict=comparison.verdict,
        difference=comparison.difference,
        ratio=comparison.ratio,
        explanation=explanation,
        checked_for=checked_for,
        shown_for=shown_for,
        steps=tuple(steps),
    )


def _is_zero(e: sp.Basic) -> bool:
    e = _residual(e)
    if isinstance(e, sp.MatrixBase):
        return all(_simplest(x) == 0 for x in e)
    return _simplest(e) == 0


def _pose(x: sp.Expr, y: sp.Expr, phi: sp.Expr) -> sp.Matrix:
    """The homogeneous matrix of a planar pose (x, y, heading phi) about z."""
    return sp.Matrix(
        [[sp.cos(phi), -sp.sin(phi), 0, x], [sp.sin(phi), sp.cos(phi), 0, y], [0, 0, 1, 0], [0, 0, 0, 1]]
    )


#: Segment counts for which the kinematic identities (Eq. 2, 14, 15) are proven case by case.
N_POE = (1, 2, 3, 4)
N_LOADS = (1, 2, 3)


def _eq1() -> AuditEntry:
    n, t = En.n_sym, S.t
    # Eq. (1): a segment of the inextensible layer is a circular arc of radius l_i turned by
    # theta_i; its length, integrated along the arc, is the segment's share L/n of the layer.
    arc = sp.Matrix([_L_I * sp.sin(_PHI), _L_I * (1 - sp.cos(_PHI))])
    speed = sp.simplify(sp.sqrt(sum(c.diff(_PHI) ** 2 for c in arc)))
    length = sp.integrate(speed, (_PHI, 0, t))
    derived = sp.Eq(S.L / n, length)
    printed = paper.eq1(n, t)
    # the bending radius the code uses solves Eq. (1)
    radius_ok = _is_zero(_residual(printed).subs(_L_I, K.joint_radius(t, n)))
    # the arc the code draws (kinematics.arc_chain) has length L/n: integrate its speed in the
    # fraction sigma of the segment
    sig = S.sigma
    x, y, _ = K.arc_chain([t], n=n, last_fraction=sig)
    seg_speed = sp.simplify(sp.sqrt(sp.simplify(sp.diff(x, sig) ** 2 + sp.diff(y, sig) ** 2)))
    tp = sp.Symbol("t", positive=True)
    seg_len = sp.simplify(sp.integrate(seg_speed.subs(t, tp), (sig, 0, 1)))
    steps = (
        Step(
            "Arc length",
            sp.Integral(speed, (_PHI, 0, t)), length,
            "The arc (l_i sin phi, l_i (1 - cos phi)) has speed l_i, so turning it by theta_i gives "
            "the length l_i theta_i, which must be the segment's share L/n of the inextensible layer.",
        ),
        Step(
            "The bending radius used by the code",
            _L_I, K.joint_radius(t, n),
            "kinematics.joint_radius solves Eq. (1) for l_i.",
            check=radius_ok,
        ),
        Step(
            "The arc drawn by the code",
            sp.Integral(seg_speed, (sig, 0, 1)), seg_len,
            "kinematics.arc_chain for one segment, parametrised by the fraction sigma of the "
            "segment: its length is L/n for every bend (shown for theta_i > 0).",
            check=_is_zero(seg_len - S.L / n),
        ),
    )
    return _entry(
        "Eq. 1",
        "Segment length and bending radius",
        printed,
        derived,
        compare(printed, derived, [t, _L_I]),
        "Identical. Eq. (1) says that each of the n equal segments of the inextensible layer is a "
        "circular arc of length L/n.",
        steps=steps,
    )


def _eq2() -> AuditEntry:
    # Eq. (2): the POE product versus the chain of tangent circular arcs built geometrically.
    cases = []
    for n in N_POE:
        th = S.theta(n)
        x, y, phi = K.arc_chain(th)
        cases.append((K.poe(th), _pose(x, y, phi)))
    comparisons = [compare(p, d, []) for p, d in cases]
    shown_p, shown_d = cases[1]
    shown_p, shown_d = shown_p.applyfunc(sp.simplify), shown_d.applyfunc(sp.simplify)
    t = S.t
    x1, y1, _ = K.arc_chain([t])
    straight = sp.Matrix([sp.limit(x1, t, 0), sp.limit(y1, t, 0)])
    steps = (
        Step(
            "The straight actuator",
            r"\lim_{\theta_1 \to 0} p_{tip}", straight,
            "With l_1 = L/theta_1 (Eq. 1) the tip tends to (L, 0) as theta_1 -> 0: the straight "
            "actuator hangs along x (vertical, downward). The POE formula is 0/0 there; the "
            "generated code uses the smooth sinc forms of derive.smooth.",
            check=_is_zero(straight - sp.Matrix([S.L, 0])),
        ),
    )
    return _entry(
        "Eq. 2",
        "Product of exponentials",
        shown_p,
        shown_d,
        _worst(comparisons),
        "Identical: the product of the joint exponentials (twists xi_i = [l_i 0 0 0 0 1], "
        "l_i = L/(n theta_i)) equals the pose at the end of n tangent circular arcs of length "
        "L/n, each turned by its theta_i. Proven entry by entry (expand_trig, then "
        "simplify/trigsimp) for each n listed; shown for n = 2. Note that g_st(0) = I holds for a "
        "fixed l_i only: since l_i = L/(n theta_i) grows without bound as theta_i -> 0, the "
        "reference configuration theta = 0 of the POE formula is not the straight actuator, "
        "whose tip lies at (L, 0).",
        checked_for="n = " + ", ".join(str(n) for n in N_POE),
        shown_for="n = 2",
        steps=steps,
    )


def _eq5() -> AuditEntry:
    n, t = En.n_sym, S.t
    printed, derived = paper.eq5_summand(n, t), En.air(n, t)
    middle = paper.eq5_middle_summand(n, t).subs(paper.R_i, K.joint_radius(t, n))
    steps = (
        Step(
            "The middle form of Eq. (5)",
            paper.eq5_middle_summand(n, t), sp.expand(middle),
            "R_i is not defined in the paper; read as the bending radius l_i = L/(n theta_i), the "
            "middle form (the cylinder's axis, r1 beyond the layer, sweeps (R_i + r1) theta_i) "
            "equals the right-hand side.",
            check=_is_zero(middle - printed),
        ),
    )
    return _entry(
        "Eq. 5",
        "Potential energy of the compressed air",
        printed,
        derived,
        compare(printed, derived, [t]),
        "Identical. The rubber is incompressible, so the chamber gains what the whole segment "
        "gains: the bent r1-cylinder (Pappus: area times the path of its centre, r1 beyond the "
        "layer) minus its straight volume pi r1^2 L/n.",
        steps=steps,
    )


def _eq8() -> AuditEntry:
    n, t = En.n_sym, S.t
    a, b = S.alpha, S.beta
    printed, derived = paper.eq8_summand(n, t), En.axial(n, t)
    sld, cmb = En.axial_parts(n, t)
    # Eq. (6)-(7) rebuilt here from the paper's text, to check energy.axial_parts
    dS_sld = 2 * S.r1**2 * sp.sin(a) ** 2  # Appendix (b)
    lam_sld = S.r1 * (1 - sp.cos(a)) * t
    dS_cmb = 2 * S.r2**2 * sp.sin(b) ** 2
    lam_cmb = (S.r1 + S.d - S.r2 * sp.cos(b)) * t
    f_sld = n * S.E * lam_sld**2 / (2 * S.L) * dS_sld  # Eq. (6)
    f_cmb = n * S.E * lam_cmb**2 / (2 * S.L) * dS_cmb  # Eq. (7)
    area = sp.integrate(dS_sld, (a, 0, sp.pi))
    steps = (
        Step(
            "Appendix (b): the strips tile the disc",
            sp.Integral(dS_sld, (a, 0, sp.pi)), area,
            "The strip at angle alpha has height r1 sin(alpha) d(alpha) and width 2 r1 sin(alpha); "
            "the strips add up to the disc's area pi r1^2. (Appendix (b) prints the width as "
            "'2 r1 sin(alpha) d(alpha)', with a stray d(alpha); the area it states is right.)",
            check=_is_zero(area - sp.pi * S.r1**2),
        ),
        Step(
            "Eq. (6) integrated: the solid cylinder",
            sp.Integral(f_sld, (a, 0, sp.pi)), sld,
            "A strip at height r1 (1 - cos alpha) above the layer stretches by r1 (1 - cos alpha) "
            "theta_i and stores n E lambda^2 dS / (2 L), a bar of length L/n.",
            check=_is_zero(sp.integrate(sp.expand(f_sld), (a, 0, sp.pi)) - sld),
        ),
        Step(
            "Eq. (7) integrated: the chamber",
            sp.Integral(f_cmb, (b, 0, sp.pi)), cmb,
            "The chamber's strip at angle beta lies r1 + d - r2 cos(beta) above the layer.",
            check=_is_zero(sp.integrate(sp.expand(f_cmb), (b, 0, sp.pi)) - cmb),
        ),
    )
    return _entry(
        "Eq. 8",
        "Axial strain energy of the rubber",
        printed,
        derived,
        compare(printed, derived, [t]),
        "Identical: the solid cylinder's integral (Eq. 6) minus the chamber's (Eq. 7).",
        steps=steps,
    )


def _eq10() -> AuditEntry:
    n, t = En.n_sym, S.t
    printed, derived = paper.eq10(n, t), En.delta_r2(n, t)
    conservation = En.volume_conservation(n, t)
    solved = En.expanded_radius_squared(n, t)
    steps = (
        Step(
            "Eq. (9): the rubber volume is conserved",
            conservation.lhs,
            conservation.rhs,
            "Before: the straight annulus pi (r1^2 - r2^2) L/n. After: the bent r1-cylinder "
            "(centre r1 beyond the layer, path L/n + r1 theta_i) minus the expanded chamber "
            "(radius r2 + Delta_r2, centre r1 + d beyond the layer, path L/n + (r1 + d) theta_i), "
            "as Eq. (9) prints it.",
        ),
        Step(
            "Eq. (9) solved",
            (S.r2 + En.Delta_r2) ** 2, solved,
            "Eq. (9) is linear in (r2 + Delta_r2)^2; Eq. (10) is its positive square root minus r2.",
            check=_is_zero((conservation.lhs - conservation.rhs).subs(En.Delta_r2, sp.sqrt(solved) - S.r2))
            and _is_zero(sp.sqrt(solved) - S.r2 - derived),
        ),
    )
    return _entry(
        "Eq. 10",
        "Radius change of the chamber",
        printed,
        derived,
        compare(printed, derived, [t]),
        "Identical.",
        steps=steps,
    )


def _eq11() -> AuditEntry:
    printed, derived = paper.eq11(), En.r1d()
    x = sp.Symbol("r_1d", positive=True)
    law = S.d**2 + x**2 - 2 * S.d * x * sp.cos(S.omega) - S.r1**2
    steps = (
        Step(
            "Cosine law",
            S.r1**2,
            S.d**2 + x**2 - 2 * S.d * x * sp.cos(S.omega),
            "In the triangle (d, r_1d, r1) with omega between d and r_1d. Its roots are "
            "d cos(omega) +- sqrt(r1^2 - d^2 sin^2(omega)); the product of the two is d^2 - r1^2 "
            "< 0 when r1 > d, so exactly one is positive: the printed one, which solves the law.",
            check=_is_zero(law.subs(x, printed)),
        ),
    )
    return _entry(
        "Eq. 11",
        "Distance from the chamber centre to the outer surface",
        printed,
        derived,
        compare(printed, derived, [S.omega]),
        "Identical.",
        steps=steps,
    )


def _eq13() -> AuditEntry:
    n, t, w = En.n_sym, S.t, S.omega
    printed, derived = paper.eq13_summand(n, t), En.radial(n, t)
    comparison = compare(printed, derived, [t])
    # Eq. (12)-(13): the integrand, reduced
    r1d, eps = En.r1d(), En.Delta_r2 / (S.r1 - S.r2)
    dS_sctr = (r1d + S.r2) / 2 * (S.L / n + S.r1 * t)  # Eq. (12), per d(omega)
    integrand = S.E * (r1d - S.r2) * eps**2 / 2 * dS_sctr
    reduced = S.E * eps**2 * (S.L / n + S.r1 * t) * (r1d**2 - S.r2**2) / 4
    lemma = sp.Integral(En.cos_sqrt_integrand(), (w, 0, 2 * sp.pi))
    r1d2 = En.r1d_squared_integral()
    # n equal segments bent by Theta/n are one arc bent by Theta: the energy must not depend on n
    Th = _THETA_TOTAL
    total_derived = sp.simplify(n * derived.subs(t, Th / n))
    total_printed = sp.simplify(n * printed.subs(t, Th / n))
    steps = (
        Step(
            "The integrand of Eq. (13)",
            integrand, reduced,
            "With r_intl = r_1d - r2, eps = Delta_r2/(r1 - r2) and dS_sctr from Eq. (12), the "
            "product (r_1d - r2)(r_1d + r2) leaves only r_1d^2 - r2^2 to integrate.",
            check=_is_zero(integrand - reduced),
        ),
        Step(
            "The vanishing lemma",
            lemma,
            sp.Integer(0),
            "Write f(omega) for the integrand. f(pi - omega) = -f(omega), so its integral over "
            "[0, pi] equals its own negative and is 0; f(2 pi - omega) = f(omega), so the integral "
            "over [pi, 2 pi] equals that over [0, pi]. (energy.cos_sqrt_integral_vanishes checks "
            "both symmetries.) This is the cross term 2 d cos(omega) sqrt(...) of r_1d^2.",
            check=En.cos_sqrt_integral_vanishes(),
        ),
        Step(
            "The integral of r_1d^2",
            sp.Integral(r1d**2, (w, 0, 2 * sp.pi)), r1d2,
            "r_1d^2 = r1^2 + d^2 cos(2 omega) + 2 d cos(omega) sqrt(r1^2 - d^2 sin^2(omega)); the "
            "middle term integrates to 0 over a period and the last by the lemma.",
            check=_is_zero(r1d2 - 2 * sp.pi * S.r1**2),
        ),
        Step(
            "Consistency: n equal segments",
            r"n \, U_{r}\big|_{\theta_i = \Theta / n}", total_derived,
            "An actuator bent uniformly by Theta is the same arc whatever n is, so its energy must "
            "not depend on n. The derived form passes; the printed one does not: its total is "
            + f"${sp.latex(total_printed.subs(S.t, THETA_I))}$.",
            check=(not total_derived.has(n)) and total_printed.has(n),
        ),
        Step(
            "One segment",
            r"\text{derived} / \text{printed}\,\big|_{n = 1}", sp.simplify(comparison.ratio.subs(n, 1)),
            "For n = 1 the two forms coincide, so the discrepancy shows only for n >= 2.",
            check=_is_zero(comparison.ratio.subs(n, 1) - 1),
        ),
    )
    return _entry(
        "Eq. 13",
        "Radial strain energy of the rubber",
        printed,
        derived,
        comparison,
        "Differs. Integrating Eq. (13)'s own integrand, with the sector area of Eq. (12), "
        "dS_sctr = (r_1d + r2)/2 (L/n + r1 theta_i) d(omega), gives the factor "
        "(L/n + r1 theta_i) = (L + n r1 theta_i)/n; the paper prints (L + r1 theta_i)/n, i.e. it "
        "divides r1 theta_i by n as well. The forms agree for n = 1 only. The derived form makes "
        "a uniformly bent actuator's energy independent of n, as it must be; it is the `paper` "
        "variant (it reproduces the paper's Table 2); the `printed` variant keeps Eq. (13) as "
        "printed.",
        steps=steps,
    )


def _eq14() -> AuditEntry:
    x, y, l = paper.x_Q, paper.y_Q, paper.l_eq14
    force = En.force_vector(_F, _OMEGA)
    derived = En.point_potential(force, sp.Matrix([x, y]), sp.Matrix([S.L, 0]))
    printed = paper.eq14(_F, _OMEGA).subs(l, S.L)
    tip_cases = []
    for n in N_LOADS:
        th = S.theta(n)
        tip = K.poe(th)[:2, 3]
        tip_cases.append(compare(printed.subs({x: tip[0], y: tip[1]}), En.payload_tip(th, _F, _OMEGA), th))
    with_l = compare(paper.eq14(_F, _OMEGA), derived, [x, y])
    comparison = _worst([compare(printed, derived, [x, y])] + tip_cases)
    steps = (
        Step(
            "The force",
            "f", force,
            "A payload F at the angle Omega from the vertical x (downward), toward -y: Omega = 0 "
            "pulls down, Omega = 90 deg pulls horizontally against the bend, as in Fig. 2. A "
            "constant force at a moving point Q has the potential -f . (Q - Q_rest), "
            "Q_rest = (L, 0) (the straight actuator).",
        ),
        Step(
            "The undefined l",
            r"\psi_{pyl}^{printed} - \psi_{pyl}^{derived}", with_l.difference,
            "Eq. (14) uses an l the paper never defines. Read as L, the potential vanishes for the "
            "straight actuator and the forms are identical; for any other l the printed form "
            "differs by this constant, which does not move the equilibrium.",
            check=with_l.verdict == UP_TO_CONSTANT,
        ),
    )
    return _entry(
        "Eq. 14",
        "Potential energy of the payload",
        printed,
        derived,
        comparison,
        "Identical, with the undefined l of Eq. (14) read as L, in the tip coordinates (x, y) and "
        "with (x, y) the POE tip (Eq. 2) for each n listed.",
        checked_for="n = " + ", ".join(str(n) for n in N_LOADS),
        steps=steps,
    )


def _midpoints(th: list[sp.Symbol]) -> list[sp.Expr]:
    """x of each segment's mid-point: Eq. (2) up to joint i, theta_i halved, twist kept."""
    n = len(th)
    return [K.poe(th[:i], n=n, last_fraction=sp.Rational(1, 2))[0, 3] for i in range(1, n + 1)]


def _eq15() -> AuditEntry:
    cases = []
    for n in N_LOADS:
        th = S.theta(n)
        cases.append((paper.eq15(_midpoints(th)), En.gravity_midpoints(th)))
    comparisons = [compare(p, d, S.theta(n)) for n, (p, d) in zip(N_LOADS, cases)]
    shown_p, shown_d = cases[1]
    t = S.t
    mid = K.poe([t], n=1, last_fraction=sp.Rational(1, 2))[0, 3]
    # the literal reading: theta_1 -> theta_1/2 everywhere, so l_1 = L/theta_1 becomes 2 L/theta_1
    literal = K.poe([t / 2], n=1)[0, 3]
    steps = (
        Step(
            "What 'replacing theta_n with theta_i/2' must mean",
            r"\begin{bmatrix} x_{mid} \\ x_{literal} \end{bmatrix}", sp.Matrix([mid, literal]),
            "The mid-point of segment i is the POE of joints 1..i with joint i turned by theta_i/2 "
            "about its own twist (l_i = L/(n theta_i) kept). Substituting theta_i/2 for theta_i "
            "everywhere, l_i included, gives instead the end of an arc of length L/n bent by "
            "theta_i/2 (shown for n = 1): a different point.",
            check=not _is_zero(mid - literal),
        ),
    )
    return _entry(
        "Eq. 15",
        "Potential energy of gravity",
        shown_p,
        shown_d,
        _worst(comparisons),
        "Identical, with x_i the mid-points of the segments on the inextensible layer, for each n "
        "listed (shown for n = 2). The derived form puts the weight M g / n of each segment at its "
        "mid-point and measures the potential from the straight actuator, which is where the "
        "constant M g L / 2 comes from. Two readings are needed: Eq. (2) has n joints, so 'the "
        "mid-point of segment i' is the product of the first i exponentials only; and the twist "
        "of joint i keeps l_i (see the step). The point is on the inextensible layer, not the "
        "centroid of the segment's rubber (about r1 away); the paper neglects gravity in its "
        "validation (Section 4.1).",
        checked_for="n = " + ", ".join(str(n) for n in N_LOADS),
        shown_for="n = 2",
        steps=steps,
    )


def _fibre_steps(variant: str) -> tuple[Step, ...]:
    balance = En.fibre_balance(variant)
    er = En.fibre_tension(variant)
    how = "as printed" if variant == "printed" else "on the projected width"
    return (
        Step(
            "Eq. (16): the force balance, " + how,
            balance.lhs,
            balance.rhs,
            f"N = (L + r1 theta_TOL)/(2 pi r1 tan(rho)) turns per fibre; the chamber width is "
            f"{'the circumference 2 pi r2' if variant == 'printed' else 'the projected width 2 r2'}.",
            check=_is_zero((balance.lhs - balance.rhs).subs(En.eta_r, er)),
        ),
        Step(
            "Solved for the fibre tension",
            En.eta_r, er,
            "Then 2 eta_a = 2 eta_r tan(rho), and psi_fbrs = 2 eta_a r1 theta_TOL (the axial "
            "displacement is r1 theta_TOL).",
            check=_is_zero(2 * er * sp.tan(S.rho) * S.r1 * En.theta_TOL - En.fibres_total(variant)),
        ),
    )


def _pressure_for_right_angle(variant: str) -> sp.Expr:
    """P that holds one segment of the Table 1 actuator at 90 degrees without payload (MPa)."""
    t = S.t
    energy = sum(En.separable(("air", "axial", "radial", "fibres"), 1, variant).values())
    gradient = sp.diff(energy, t).subs(TABLE_1).subs(t, sp.pi / 2)
    (pressure,) = sp.solve(gradient, S.P)  # the energy is linear in P
    return pressure


def _eq18() -> AuditEntry:
    printed, derived = paper.eq18(En.theta_TOL), En.fibres_total("printed")
    return _entry(
        "Eq. 18",
        "Potential energy of the fibres (as printed)",
        printed,
        derived,
        compare(printed, derived, [En.theta_TOL]),
        "Identical: Eq. (18) follows from Eq. (16) as printed, where the radial force of the "
        "chamber acts on its circumference 2 pi r2. This is the `printed` variant.",
        steps=_fibre_steps("printed"),
    )


def _eq18_paper() -> AuditEntry:
    printed, derived = paper.eq18(En.theta_TOL), En.fibres_total("paper")
    comparison = compare(printed, derived, [En.theta_TOL])
    p_paper, p_printed = (_pressure_for_right_angle(v) for v in ("paper", "printed"))
    pressures = sp.Matrix([sp.Float(f"{float(sp.N(p, 15)):.4f}") for p in (p_paper, p_printed)])
    steps = _fibre_steps("paper") + (
        Step(
            "The width",
            r"w_{printed} / w_{paper}", sp.simplify(paper.eq16_width() / En.fibre_width("paper")),
            "The pressure on a half-cylinder of radius r2 pushes across its diametral plane with "
            "P times the projected width 2 r2 per unit length (as in the hoop-stress balance), not "
            "P times the circumference 2 pi r2.",
            check=_is_zero(paper.eq16_width() / En.fibre_width("paper") - sp.pi),
        ),
        Step(
            "Which one the paper computed with",
            r"\begin{bmatrix} P_{90^\circ}^{paper} \\ P_{90^\circ}^{printed} \end{bmatrix}", pressures,
            "The pressure (MPa) that holds the Table 1 actuator at 90 deg without payload, one "
            "segment (Eq. 13 is the same in both variants for n = 1): "
            f"{float(pressures[0]):.4f} with the paper variant, {float(pressures[1]):.4f} with the "
            "printed one. Section 4.4.2 reports 0.123 MPa for the analytical model: only the paper "
            "variant comes close.",
            check=bool(abs(pressures[0] - PAPER_P_90DEG) < 1e-3 < abs(pressures[1] - PAPER_P_90DEG)),
        ),
    )
    return _entry(
        "Eq. 16/18 (paper variant)",
        "Potential energy of the fibres (the model behind the paper's numbers)",
        printed,
        derived,
        comparison,
        "Differs by the factor pi: printed = pi x derived. Eq. (18) as printed follows from "
        "Eq. (16) as printed (see Eq. 18), but the paper's numbers (the 0.123 MPa of Section "
        "4.4.2, Table 2) are reproduced only when the fibre force balance of Eq. (16) uses the "
        "projected chamber width 2 r2 instead of the circumference 2 pi r2, which leaves one pi "
        "in Eq. (18) instead of pi^2. This is the `paper` variant.",
        steps=steps,
    )


def _appendix_a() -> AuditEntry:
    w = sp.Matrix(sp.symbols("omega_1 omega_2 omega_3", real=True))
    printed, derived = paper.hat_omega_printed(w), K.skew(w)
    z = sp.Matrix([0, 0, 1])
    v = sp.Matrix(sp.symbols("v_1 v_2 v_3", real=True))
    l = _L_I
    theta = sp.Symbol("theta", real=True)
    hz = paper.hat_omega_printed(z)
    steps = (
        Step(
            "Not skew-symmetric",
            r"\hat\omega_{printed} + \hat\omega_{printed}^T", printed + printed.T,
            "A cross-product matrix is skew-symmetric; the printed one is not unless omega_1 = omega_3.",
            check=not _is_zero(printed + printed.T),
        ),
        Step(
            "The z-axis of Section 3.1",
            r"\left[\hat\omega_{printed} \;\middle|\; \hat\omega_{printed} v \;\middle|\; "
            r"\omega \times v\right]_{\omega = e_z}",
            sp.Matrix.hstack(hz, hz * v, z.cross(v)),
            "For omega = (0, 0, 1), the axis of every joint in Section 3.1: the printed matrix, what "
            "it does to a vector v, and the cross product it should give. The printed one maps v to "
            "(0, v_1, 0) instead of omega x v = (-v_2, v_1, 0).",
            check=(not _is_zero(hz * v - z.cross(v))) and _is_zero(K.skew(z) * v - z.cross(v)),
        ),
        Step(
            "Its exponential is a shear",
            r"e^{\hat\omega_{printed} \theta}\ (\omega = e_z)", (hz * theta).exp(),
            "Used in the POE formula, the printed matrix would shear the plane instead of turning it.",
            check=not _is_zero((hz * theta).exp() - (K.skew(z) * theta).exp()),
        ),
        Step(
            "The twist of Section 3.1 is right",
            K.twist(z, sp.Matrix([0, l, 0])), paper.twist_printed(l),
            "xi = [-omega x q; omega] with omega = (0, 0, 1), q = (0, l_i, 0) is "
            "[l_i 0 0 0 0 1]^T, as printed: the error is confined to the Appendix's hat map, and "
            "the code (kinematics.skew) uses the correct one.",
            check=_is_zero(K.twist(z, sp.Matrix([0, l, 0])) - paper.twist_printed(l)),
        ),
    )
    return _entry(
        "Appendix (a)",
        "The hat map of the rotation axis",
        printed,
        derived,
        compare(printed, derived, list(w)),
        "Differs: the printed omega-hat has -omega_1 in row 1, column 2, where -omega_3 belongs. "
        "A typo with consequences only for a reader who implements it: the twists and Eq. (2) "
        "are right with the correct map.",
        steps=steps,
    )


# ---------------------------------------------------------------------------------------------
# The paper's results tables: rows that must agree

#: The EXP and FEM columns of the results tables, degrees, as printed: the first row
#: (theta_EXP / theta_FEM) and the theta_TOL row. For these columns both rows are the same measured
#: total angle (Table 2 prints it twice). Table 2: 2 N horizontal tip payload; Table 3: 2 N vertical.
PAPER_TABLES: dict[str, dict[str, tuple[float, float]]] = {
    "Table 2": {"first row": (28.8, 32.4), "theta_TOL": (28.8, 32.4)},
    "Table 3": {"first row": (28.8, 32.4), "theta_TOL": (53.2, 50.2)},
}


@dataclass(frozen=True)
class TableCheck:
    """One consistency check of the results tables: what is compared and whether it holds."""

    title: str
    holds: bool


def table_checks() -> tuple[TableCheck, ...]:
    """The first row against the theta_TOL row in each table, and Table 3's first row against Table 2's."""
    t2, t3 = PAPER_TABLES["Table 2"], PAPER_TABLES["Table 3"]
    return (
        TableCheck("Table 2: first row (θ_EXP, θ_FEM) = θ_TOL row", t2["first row"] == t2["theta_TOL"]),
        TableCheck("Table 3: first row (θ_EXP, θ_FEM) = θ_TOL row", t3["first row"] == t3["theta_TOL"]),
        TableCheck("Table 3's first row = Table 2's first row (the horizontal case's angles)", t3["first row"] == t2["first row"]),
    )


_BUILDERS = (_eq1, _eq2, _eq5, _eq8, _eq10, _eq11, _eq13, _eq14, _eq15, _eq18, _eq18_paper, _appendix_a)


@lru_cache(maxsize=None)
def entries() -> tuple[AuditEntry, ...]:
    """Every audit entry, in the paper's order (computed once per process)."""
    return tuple(build() for build in _BUILDERS)


def verdicts() -> dict[str, AuditEntry]:
    """The audit entries by key (``"Eq. 13"``, ..., ``"Appendix (a)"``); a fresh dict."""
    return {e.key: e for e in entries()}
