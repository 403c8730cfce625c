"""The generated models checked by numbers (PyDy style), not by text.

For each segment count and variant, at random points that include straight segments (theta_i = 0
exactly), +-1e-9 and negative angles: the SymPy reference (brute-force differentiation), the
generated CasADi gradient and Hessian, CasADi's own AD of the generated energy, and central finite
differences must agree. n = 1 is also checked against a closed form derived by hand below.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from esba.model.generated import EffectSet, load_model
from tests import reference
from tests.conftest import TABLE1
from tests.tolerances import FD_ATOL, FD_RTOL, FD_STEP, KERNEL_ATOL, KERNEL_RTOL

DEFAULT = "air,axial,radial,fibres,payload"
ALL = "air,axial,radial,fibres,payload:2,gravity"


def parameter_values(effects: EffectSet, rng: np.random.Generator) -> dict:
    """Table 1 with a random pressure and random payloads (mid-length and tip), and gravity."""
    v = dict(TABLE1, P=float(rng.uniform(0.0, 0.2)))
    for k in range(1, effects.payloads + 1):
        v[f"F{k}"] = float(rng.uniform(0.1, 3.0))
        v[f"Omega{k}"] = float(rng.uniform(0, 2 * math.pi))
        v[f"s{k}"] = 1.0 if k == 1 else float(rng.uniform(0.05, 0.95))
    if effects.gravity:
        v["M"], v["g"] = 0.035, 9.81
    return {k: v[k] for k in effects.parameters()}


def theta_points(n: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Hard and random points: all straight, tiny angles, negative, a mixed chain."""
    pts = [
        np.zeros(n),
        np.full(n, 1e-9),
        np.full(n, -1e-9),
        rng.uniform(-0.05, 0.6, n),
        rng.uniform(0.2, 1.2, n),
    ]
    mixed = rng.uniform(-0.05, 0.8, n)
    mixed[:: 2] = 0.0  # straight segments between bent ones
    pts.append(mixed)
    return pts


def close(a, b, rtol=KERNEL_RTOL, atol=KERNEL_ATOL, scale=1.0):
    np.testing.assert_allclose(np.asarray(a, float), np.asarray(b, float), rtol=rtol, atol=atol * scale)


def casadi_ad(model, values):
    """Gradient and Hessian Functions by CasADi's own AD of the generated energy."""
    th = ca.SX.sym("th", model.n)
    U = model["energy"](th, *model.param_vector(values))[0]
    g, H = ca.gradient(U, th), ca.hessian(U, th)[0]
    return ca.Function("g", [th], [g]), ca.Function("H", [th], [H])


CASES = [(n, DEFAULT, v) for n in (1, 2, 3, 5, 8) for v in ("paper", "printed")] + [
    (n, ALL, "paper") for n in (1, 2, 3, 5)
] + [(3, ALL, "printed")]


@pytest.mark.parametrize("n,effects,variant", CASES)
def test_generated_matches_sympy_ad_and_fd(n, effects, variant):
    rng = np.random.default_rng(1000 * n + len(effects) + len(variant))
    eff = EffectSet.parse(effects)
    model = load_model(n, eff, variant)
    values = parameter_values(eff, rng)
    p = model.param_vector(values)
    ad_g, ad_H = casadi_ad(model, values)
    for theta in theta_points(n, rng):
        U = model.energy(theta, p)
        g = model.gradient(theta, p)
        H = model.hessian(theta, p)
        assert np.all(np.isfinite(g)) and np.all(np.isfinite(H)) and math.isfinite(U)
        scale = 1.0 + abs(U)
        # SymPy, differentiated by brute force
        U_ref, g_ref, H_ref = reference.evaluate(n, eff, variant, values, theta)
        close(U, U_ref, scale=scale)
        close(g, g_ref, scale=scale)
        close(H, H_ref, scale=scale)
        # CasADi's own AD of the generated energy
        close(g, np.asarray(ad_g(theta)).ravel(), scale=scale)
        close(H, np.asarray(ad_H(theta)), scale=scale)
        # Hessian symmetric
        close(H, H.T, scale=scale)
        # central finite differences of U (gradient) and of the gradient (Hessian)
        eye = np.eye(n) * FD_STEP
        g_fd = [(model.energy(theta + e, p) - model.energy(theta - e, p)) / (2 * FD_STEP) for e in eye]
        H_fd = np.array([(model.gradient(theta + e, p) - model.gradient(theta - e, p)) / (2 * FD_STEP) for e in eye])
        close(g, g_fd, rtol=FD_RTOL, atol=FD_ATOL, scale=scale)
        close(H, H_fd, rtol=FD_RTOL, atol=FD_ATOL, scale=scale)


def hand_energy_n1(th: float, v: dict, variant: str) -> float:
    """U for n = 1 with a tip payload, written out by hand from Eq. 5, 8, 10, 13 (derived), 14, 18.

    One segment is one arc of radius L/th: tip (L sin th / th, L (1 - cos th) / th).
    """
    L, r1, r2, d, E, P, rho = (v[k] for k in ("L", "r1", "r2", "d", "E", "P", "rho"))
    F, Om = v["F1"], v["Omega1"]
    air = -P * math.pi * r1**3 * th
    axial = th**2 * E * math.pi * (5 * r1**4 - 4 * r2**2 * (r1 + d) ** 2 - r2**4) / (8 * L)
    dr = math.sqrt((L * r2**2 + r1**3 * th) / (L + (d + r1) * th)) - r2
    factor = L + r1 * th  # n r1 = r1 for n = 1: both variants agree here
    radial = E * math.pi * factor * (r1 + r2) / (2 * (r1 - r2)) * dr**2
    fibres = 4 * P * (math.pi if variant == "paper" else math.pi**2) * r1**2 * r2 * th * math.tan(rho) ** 2
    x, y = L * math.sin(th) / th, L * (1 - math.cos(th)) / th
    payload = y * F * math.sin(Om) + (L - x) * F * math.cos(Om)
    return air + axial + radial + fibres + payload


@pytest.mark.parametrize("variant", ["paper", "printed"])
@pytest.mark.parametrize("th", [-0.05, 0.01, 0.3, 1.0, 1.5707963, 2.5])
def test_n1_against_hand_closed_form(th, variant):
    v = dict(TABLE1, P=0.12, F1=2.0, Omega1=math.radians(90), s1=1.0)
    model = load_model(1, DEFAULT, variant)
    U = model.energy([th], v)
    assert U == pytest.approx(hand_energy_n1(th, v, variant), rel=1e-12, abs=1e-10)
    h = 1e-6
    g_fd = (hand_energy_n1(th + h, v, variant) - hand_energy_n1(th - h, v, variant)) / (2 * h)
    assert model.gradient([th], v)[0] == pytest.approx(g_fd, rel=1e-6, abs=1e-6)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_straight_actuator_has_zero_energy_and_pose(n):
    """theta = 0 exactly: every term vanishes except none, and the tip is at (L, 0)."""
    model = load_model(n, ALL if n <= 3 else DEFAULT)
    rng = np.random.default_rng(n)
    values = parameter_values(model.effects, rng)
    theta = np.zeros(n)
    assert model.energy(theta, values) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(model.tip(theta, values["L"]), [values["L"], 0.0, 0.0], atol=1e-12)
    pts = model.points(theta, values["L"])
    np.testing.assert_allclose(pts[0], np.linspace(0, values["L"], n + 1), atol=1e-12)


@pytest.mark.parametrize("n", [1, 3, 8])
def test_reverse_mode_ad_is_finite_at_straight_segments(n):
    """CasADi's reverse mode through the generated kinematics and gradient, at theta = 0 exactly
    and with a payload point on a segment end (sigma = 0 beyond it): finite. The SX ``if_else``
    evaluates both branches of the smooth sinc forms, and a NaN partial of the unused quotient
    times a zero seed is NaN (the fit of a straight row died on it)."""
    model = load_model(n, ALL)
    values = parameter_values(model.effects, np.random.default_rng(n))
    values["s2"] = 1.0 / n  # payload 2 at the end of the first segment
    th = ca.SX.sym("th", n)
    tip = model["kinematics"](th, values["L"])[0]
    G = model["gradient"](th, *model.param_vector(values))
    f = ca.Function("f", [th], [ca.gradient(ca.sumsqr(tip), th), ca.gradient(ca.sumsqr(G), th), ca.hessian(ca.sumsqr(tip) + ca.sumsqr(G), th)[0]])
    for theta in (np.zeros(n), np.r_[0.3, np.zeros(n - 1)]):
        for out in f(theta):
            assert np.all(np.isfinite(np.asarray(out))), (n, theta)


@pytest.mark.parametrize("n", [1, 2, 4])
def test_centreline_matches_segment_points_and_tip(n):
    model = load_model(n)
    theta = np.linspace(-0.1, 0.7, n)
    L = 135.0
    cl = model.centreline(theta, L, samples=4 * n + 1)
    pts = model.points(theta, L)
    np.testing.assert_allclose(cl[:: 4, :2].T, pts, atol=1e-10)
    assert cl[-1, 2] == pytest.approx(theta.sum())
