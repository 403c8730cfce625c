"""Kinematics: the exponential map, the smooth forms at theta = 0, and the chain-sum rule."""

from __future__ import annotations

import random

import pytest
import sympy as sp

from esba.derive import symbols as S
from esba.derive.kinematics import (
    arc_chain,
    chain_sum_derivatives,
    chord,
    exp_twist,
    fraction_in_segment,
    hat,
    poe,
    segment_twist,
    skew,
    twist,
)
from esba.derive.smooth import SINC_SWITCH, sinc, versinc


def test_twist_of_a_joint_through_0_l_0_about_z():
    """Section 3.1: q_i = (0, l_i, 0), omega = z gives xi_i = [l_i, 0, 0, 0, 0, 1]."""
    l = sp.Symbol("l", positive=True)
    assert twist(sp.Matrix([0, 0, 1]), sp.Matrix([0, l, 0])) == sp.Matrix([l, 0, 0, 0, 0, 1])


def test_skew_is_the_cross_product_matrix():
    a, b = sp.Matrix(sp.symbols("a1:4")), sp.Matrix(sp.symbols("b1:4"))
    assert sp.simplify(skew(a) * b - a.cross(b)) == sp.zeros(3, 1)


@pytest.mark.parametrize("l,th", [(3.0, 0.7), (-2.0, 1.9), (50.0, -0.2)])
def test_exp_twist_is_the_matrix_exponential(l, th):
    xi = sp.Matrix([l, 0, 0, 0, 0, 1])
    general = (hat(xi) * sp.Float(th)).exp()
    assert sp.Matrix(general - exp_twist(xi, sp.Float(th))).norm() < 1e-12


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_poe_equals_chain_of_tangent_arcs(n):
    """Eq. (2) proven symbolically: the POE end pose is the chain of tangent circular arcs."""
    th = S.theta(n)
    g = poe(th)
    x, y, phi = arc_chain(th)
    assert sp.simplify(sp.expand_trig(g[0, 3] - x)) == 0
    assert sp.simplify(sp.expand_trig(g[1, 3] - y)) == 0
    assert sp.simplify(g[:2, :2] - sp.Matrix([[sp.cos(phi), -sp.sin(phi)], [sp.sin(phi), sp.cos(phi)]])) == sp.zeros(2, 2)


def test_segment_twist_radius_is_eq1():
    t = S.t
    assert segment_twist(t, 3)[0] == S.L / (3 * t)


# ---------------------------------------------------------------------------------------------
# Smooth forms: value, first and second derivative exact at 0 (SymForce-style limit checks)


@pytest.mark.parametrize("f,naive", [(sinc, lambda u: sp.sin(u) / u), (versinc, lambda u: (1 - sp.cos(u)) / u)])
@pytest.mark.parametrize("order", [0, 1, 2])
def test_smooth_forms_have_the_right_limits_at_zero(f, naive, order):
    u = sp.Symbol("u", real=True)
    smooth_at_0 = sp.diff(f(u), u, order).subs(u, 0)
    assert smooth_at_0 == sp.limit(sp.diff(naive(u), u, order), u, 0)


@pytest.mark.parametrize("f,naive", [(sinc, lambda u: sp.sin(u) / u), (versinc, lambda u: (1 - sp.cos(u)) / u)])
@pytest.mark.parametrize("u0", [1e-9, -1e-9, 1e-4, 0.0999, 0.1001, -0.5, 2.0])
def test_smooth_forms_match_the_exact_function_off_zero(f, naive, u0):
    """At 50 digits, the branch chosen agrees with the exact function to round-off, derivatives too."""
    u = sp.Symbol("u", real=True)
    for order in (0, 1, 2):
        got = sp.diff(f(u), u, order).subs(u, sp.Float(u0, 50)).evalf(50)
        want = sp.diff(naive(u), u, order).subs(u, sp.Float(u0, 50)).evalf(50)
        assert abs(got - want) < 1e-13 * (1 + abs(want)), (order, got, want)


def test_chord_of_a_straight_segment():
    """theta = 0: the chord is (sigma L/n, 0); its derivatives are the limits of the arc's."""
    n, sig, t = 4, sp.Rational(1, 3), S.t
    c = chord(t, sig, n)
    l = S.L / (n * t)
    arc = sp.Matrix([l * sp.sin(sig * t), l * (1 - sp.cos(sig * t))])
    for order in (0, 1, 2):
        at0 = sp.diff(c, t, order).subs(t, 0)
        lim = sp.Matrix([sp.limit(sp.diff(a, t, order), t, 0) for a in arc])
        assert sp.simplify(at0 - lim) == sp.zeros(2, 1)


def test_switch_point_is_documented_value():
    assert SINC_SWITCH == sp.Rational(1, 10)


# ---------------------------------------------------------------------------------------------
# The chain-sum rule (screw-theory Jacobian) against brute-force differentiation


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_chain_sum_derivatives_match_brute_force(n):
    th = S.theta(n)
    a = [sp.Function(f"a{k}")(th[k]) for k in range(n)]
    b = [sp.Function(f"b{k}")(th[k]) for k in range(n)]
    phis = [sum(th[:k], sp.Integer(0)) for k in range(n)]
    cos_phi = [sp.cos(p) for p in phis]
    sin_phi = [sp.sin(p) for p in phis]
    v = [(a[k], b[k]) for k in range(n)]
    dv = [(sp.diff(a[k], th[k]), sp.diff(b[k], th[k])) for k in range(n)]
    ddv = [(sp.diff(a[k], th[k], 2), sp.diff(b[k], th[k], 2)) for k in range(n)]
    Q, D, DD, _ = chain_sum_derivatives(cos_phi, sin_phi, v, dv, ddv, lambda name, e: e, "t")
    Qx = sum(cos_phi[k] * a[k] - sin_phi[k] * b[k] for k in range(n))
    Qy = sum(sin_phi[k] * a[k] + cos_phi[k] * b[k] for k in range(n))
    for j in range(n):
        assert sp.simplify(D[j][0] - sp.diff(Qx, th[j])) == 0
        assert sp.simplify(D[j][1] - sp.diff(Qy, th[j])) == 0
        assert sp.simplify(DD[j][0] - sp.diff(Qx, th[j], 2)) == 0
        assert sp.simplify(DD[j][1] - sp.diff(Qy, th[j], 2)) == 0
        for k in range(j + 1, n):
            # off the diagonal: J dQ/dtheta_k, J (x, y) = (-y, x)
            assert sp.simplify(-D[k][1] - sp.diff(Qx, th[j], th[k])) == 0
            assert sp.simplify(D[k][0] - sp.diff(Qy, th[j], th[k])) == 0


@pytest.mark.parametrize("s,expect", [(0.0, [0, 0, 0]), (1.0, [1, 1, 1]), (0.5, [1, 0.5, 0]), (2 / 3, [1, 1, 0]), (0.9, [1, 1, 0.7])])
def test_fraction_in_segment(s, expect):
    got = [float(fraction_in_segment(sp.Float(s), k, 3)) for k in (1, 2, 3)]
    assert got == pytest.approx(expect)


def test_random_points_on_the_poe_chain_match_the_chord_chain():
    """The pose at any arc length (POE with the last joint turned part-way) is the chord chain."""
    rng = random.Random(3)
    n = 3
    vals = {S.L: 135}
    th = [sp.Float(rng.uniform(-0.3, 1.0)) for _ in range(n)]
    for _ in range(4):
        k, frac = rng.randint(1, n), rng.uniform(0.05, 1.0)
        g = poe(th[:k], n=n, last_fraction=sp.Float(frac))
        x = y = sp.Integer(0)
        phi = sp.Integer(0)
        for i in range(k):
            sig = sp.Float(frac) if i == k - 1 else 1
            c = chord(th[i], sig, n)
            x += sp.cos(phi) * c[0] - sp.sin(phi) * c[1]
            y += sp.sin(phi) * c[0] + sp.cos(phi) * c[1]
            phi += th[i]
        assert abs(float((g[0, 3] - x).subs(vals))) < 1e-10
        assert abs(float((g[1, 3] - y).subs(vals))) < 1e-10
