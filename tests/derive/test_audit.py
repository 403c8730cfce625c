"""The audit of the paper's equations (derive/audit.py) and its page, docs/derivations.md (rendered by
derive/audit_page.py; written and checked by esba.pages.derivations, tests/pages/test_derivations.py).

Every verdict is asserted, every intermediate step is checked against a result derived by hand,
and the committed page must be what ``esba audit`` writes now.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import sympy as sp
from scipy.integrate import quad

from esba.derive import audit, audit_page, paper
from esba.derive import energy as En
from esba.derive import kinematics as K
from esba.derive import symbols as S
from esba import cli

ROOT = Path(__file__).resolve().parents[2]
n, t = En.n_sym, S.t
L, r1, r2, d, E, P, rho = S.L, S.r1, S.r2, S.d, S.E, S.P, S.rho

#: Absolute tolerance of scipy's adaptive quadrature on O(10) integrands (round-off level).
QUAD_ATOL = 1e-10


@pytest.fixture(scope="module")
def entries():
    return audit.verdicts()


def _zero(e) -> bool:
    return sp.simplify(e) == 0


# ---------------------------------------------------------------------------------------------
# Verdicts

EXPECTED = {
    "Eq. 1": audit.IDENTICAL,
    "Eq. 2": audit.IDENTICAL,
    "Eq. 5": audit.IDENTICAL,
    "Eq. 8": audit.IDENTICAL,
    "Eq. 10": audit.IDENTICAL,
    "Eq. 11": audit.IDENTICAL,
    "Eq. 13": audit.DIFFERS,
    "Eq. 14": audit.IDENTICAL,
    "Eq. 15": audit.IDENTICAL,
    "Eq. 18": audit.IDENTICAL,
    "Eq. 16/18 (paper variant)": audit.DIFFERS,
    "Appendix (a)": audit.DIFFERS,
}


def test_every_equation_is_audited(entries):
    assert list(entries) == list(EXPECTED)


@pytest.mark.parametrize("key", list(EXPECTED))
def test_verdict(entries, key):
    e = entries[key]
    assert e.verdict == EXPECTED[key]
    if e.verdict == audit.IDENTICAL:
        assert e.difference is None and e.ratio is None
    else:
        assert e.difference is not None
        assert e.explanation.startswith("Differs")


@pytest.mark.parametrize("key", list(EXPECTED))
def test_every_step_check_holds(entries, key):
    checks = [(s.title, s.check) for s in entries[key].steps if s.check is not None]
    assert checks, f"{key} has no checked step"
    assert all(ok is True for _, ok in checks), checks


def test_eq13_ratio_is_the_segment_length_factor(entries):
    e = entries["Eq. 13"]
    # Eq. (12): dS_sctr uses L/n + r1 theta_i, so n (L/n + r1 theta_i) = L + n r1 theta_i
    assert _zero(e.ratio - (L + n * r1 * t) / (L + r1 * t))
    assert _zero(e.ratio - En.radial_factor_ratio())
    assert e.ratio.subs(n, 1) == 1


def test_eq13_uniform_bend_is_independent_of_n():
    Theta = sp.Symbol("Theta", positive=True)
    derived = sp.simplify(n * En.radial(n, t).subs(t, Theta / n))
    printed = sp.simplify(n * paper.eq13_summand(n, t).subs(t, Theta / n))
    assert not derived.has(n)
    assert printed.has(n)
    # the n = 1 energy, hand-integrated: E pi (L + r1 Theta)(r1 + r2)/(2 (r1 - r2)) Delta^2
    dr = sp.sqrt((L * r2**2 + r1**3 * Theta) / (L + (d + r1) * Theta)) - r2
    assert _zero(derived - E * sp.pi * (L + r1 * Theta) * (r1 + r2) / (2 * (r1 - r2)) * dr**2)


def test_eq16_18_paper_variant_differs_by_pi(entries):
    e = entries["Eq. 16/18 (paper variant)"]
    assert _zero(e.printed / e.derived - sp.pi)  # printed / paper variant = pi
    assert _zero(e.ratio - 1 / sp.pi)  # the entry's ratio is derived / printed
    assert _zero(e.derived - 4 * P * sp.pi * r1**2 * r2 * En.theta_TOL * sp.tan(rho) ** 2)


def test_appendix_a_hat_map(entries):
    e = entries["Appendix (a)"]
    w1, w2, w3 = sp.symbols("omega_1 omega_2 omega_3", real=True)
    assert e.difference == sp.Matrix([[0, w3 - w1, 0], [0, 0, 0], [0, 0, 0]])
    z = sp.Matrix([0, 0, 1])
    v = sp.Matrix([1, 2, 3])
    assert paper.hat_omega_printed(z) * v != z.cross(v)
    assert K.skew(z) * v == z.cross(v)
    l = sp.Symbol("l", positive=True)
    assert K.twist(z, sp.Matrix([0, l, 0])) == paper.twist_printed(l)


def test_eq14_constant_for_other_l(entries):
    x, y, l = paper.x_Q, paper.y_Q, paper.l_eq14
    F, Om = sp.symbols("F Omega", real=True)
    derived = En.point_potential(En.force_vector(F, Om), sp.Matrix([x, y]), sp.Matrix([L, 0]))
    c = audit.compare(paper.eq14(F, Om), derived, [x, y])
    assert c.verdict == audit.UP_TO_CONSTANT
    assert _zero(c.difference - F * sp.cos(Om) * (l - L))
    assert entries["Eq. 14"].checked_for == "n = 1, 2, 3"


def test_eq2_and_eq15_are_proven_case_by_case(entries):
    assert entries["Eq. 2"].checked_for == "n = 1, 2, 3, 4"
    assert entries["Eq. 15"].checked_for == "n = 1, 2, 3"


# ---------------------------------------------------------------------------------------------
# The derivation steps, against results derived by hand


def test_eq1_arc_length():
    l_i, phi = sp.Symbol("l_i", positive=True), sp.Symbol("phi", real=True)
    assert sp.integrate(l_i, (phi, 0, t)) == l_i * t
    assert _zero(K.joint_radius(t, n) * t - L / n)


def test_axial_parts_hand_results():
    sld, cmb = En.axial_parts(n, t)
    assert _zero(sld - 5 * sp.pi * n * E * r1**4 * t**2 / (8 * L))
    assert _zero(cmb - n * E * sp.pi * t**2 * (4 * r2**2 * (r1 + d) ** 2 + r2**4) / (8 * L))


def test_eq9_is_the_printed_volume_balance():
    Dr = En.Delta_r2
    # Eq. (9) as printed, transcribed here as a hand check
    printed = sp.Eq(
        sp.pi * L / n * (r1**2 - r2**2),
        sp.pi * r1**2 * (L / n + r1 * t) - sp.pi * (r2 + Dr) ** 2 * (L / n + r1 * t + d * t),
    )
    derived = En.volume_conservation(n, t)
    assert _zero((printed.lhs - printed.rhs) - (derived.lhs - derived.rhs))


def test_eq10_solves_eq9():
    eq = En.volume_conservation(n, t)
    assert _zero((eq.lhs - eq.rhs).subs(En.Delta_r2, En.delta_r2(n, t)))


def test_r1d_squared_integral():
    assert _zero(En.r1d_squared_integral() - 2 * sp.pi * r1**2)


def test_vanishing_lemma_symbolic():
    assert En.cos_sqrt_integral_vanishes()


@pytest.mark.parametrize("r1_, d_", [(8.0, 4.0), (8.0, 0.0), (8.0, 7.9), (1.0, 0.5), (3.0, 2.999)])
def test_vanishing_lemma_numeric(r1_, d_):
    def f(w):
        return math.cos(w) * math.sqrt(r1_**2 - d_**2 * math.sin(w) ** 2)

    full, _ = quad(f, 0.0, 2 * math.pi, limit=200)
    assert abs(full) < QUAD_ATOL
    # not vacuous: over a quarter period the integrand does not cancel
    quarter, _ = quad(f, 0.0, math.pi / 2)
    assert quarter > 0.1


def test_r1d_squared_integral_numeric():
    r1_, d_ = 8.0, 4.0

    def r1d(w):
        return math.sqrt(r1_**2 - d_**2 * math.sin(w) ** 2) + d_ * math.cos(w)

    val, _ = quad(lambda w: r1d(w) ** 2, 0.0, 2 * math.pi)
    assert val == pytest.approx(2 * math.pi * r1_**2, rel=1e-12)


@pytest.mark.parametrize(
    "variant, eta_r",
    [
        ("printed", 2 * sp.pi**2 * P * r1 * r2 * sp.tan(rho)),
        ("paper", 2 * sp.pi * P * r1 * r2 * sp.tan(rho)),
    ],
)
def test_fibre_force_balance(variant, eta_r):
    N = (L + r1 * En.theta_TOL) / (2 * sp.pi * r1 * sp.tan(rho))
    balance = 2 * N * eta_r - En.fibre_width(variant) * (L + r1 * En.theta_TOL) * P
    assert _zero(balance)
    # 2 eta_a = 2 eta_r tan(rho), times the axial displacement r1 theta_TOL
    assert _zero(2 * eta_r * sp.tan(rho) * r1 * En.theta_TOL - En.fibres_total(variant))


def test_pressure_for_right_angle_matches_section_4_4_2():
    p_paper = float(sp.N(audit._pressure_for_right_angle("paper"), 15))
    p_printed = float(sp.N(audit._pressure_for_right_angle("printed"), 15))
    # Section 4.4.2: the analytical model needs 0.123 MPa for 90 deg
    assert abs(p_paper - 0.123) < 1e-3
    assert abs(p_printed - 0.123) > 1e-2


# ---------------------------------------------------------------------------------------------
# compare()


def test_compare_categories():
    x = sp.Symbol("x", real=True)
    assert audit.compare(sp.cos(x) ** 2, 1 - sp.sin(x) ** 2, [x]).verdict == audit.IDENTICAL
    c = audit.compare(x + 5, x, [x])
    assert (c.verdict, c.difference, c.ratio) == (audit.UP_TO_CONSTANT, 5, None)
    c = audit.compare(x**2, x, [x])
    assert c.verdict == audit.DIFFERS and _zero(c.ratio - 1 / x)
    assert audit.compare(sp.Eq(x, 2), sp.Eq(x - 2, 0), [x]).verdict == audit.IDENTICAL
    m = audit.compare(sp.Matrix([x, 1]), sp.Matrix([x, 2]), [x])
    assert m.verdict == audit.DIFFERS and m.difference == sp.Matrix([0, -1])


# ---------------------------------------------------------------------------------------------
# The page


def test_page_is_deterministic():
    assert audit_page.render.__wrapped__() == audit_page.render()


def test_page_content(entries):
    page = audit_page.render()
    assert "FAILS" not in page
    for key, e in entries.items():
        assert f"## {key}\n" in page
        assert f"| {e.verdict} |" in page
    assert page.count("$$") % 2 == 0


def test_cli_writes_page(tmp_path, capsys):
    out = tmp_path / "page.md"
    assert cli.main(["audit", "--out", str(out)]) == 0
    assert "Eq. 16/18 (paper variant)" in capsys.readouterr().out
    assert out.read_text().startswith(audit_page.render())  # then the section's assumed parameters (tests/pages/test_derivations.py)


def test_committed_page_is_current():
    assert (ROOT / "docs" / "derivations.md").is_file(), "run `esba audit` and commit docs/derivations.md"
    assert cli.main(["audit", "--check"]) == 0


def test_table3_copy_error_is_found_and_on_the_page():
    """Table 3's first row repeats Table 2's (the horizontal case); its theta_TOL row is the vertical case."""
    checks = {c.title.split(":")[0] if ":" in c.title else c.title: c.holds for c in audit.table_checks()}
    assert checks["Table 2"] is True
    assert checks["Table 3"] is False
    assert audit.table_checks()[2].holds  # the copy
    text = audit_page.render()
    assert "## The paper's tables" in text and "**Table 3 has a copy error**" in text and "53.2" in text
