"""The spatial model family: the SE(3) segment template, the generated gradient and Hessian, the
committed m3d_ models, and the restriction to the planar model."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg as sl
import sympy as sp

from esba.derive import spatial as X
from esba.derive.effects import EffectError
from esba.derive.effects3d import Effects3D, source_hash_3d
from esba.derive.emit import _exec_source
from esba.derive.provenance import GENERATED_DIR

VALUES = dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=0.17, E=0.54, P=0.05, EI_side=2000.0, GJ=1500.0, EI=3000.0, kappa0=0.002,
              F1=1.5, Omega1=0.7, Beta1=0.4, s1=0.73, F2=0.8, Omega2=-0.3, Beta2=-1.1, s2=0.21,
              mx1=10.0, my1=-20.0, mz1=30.0, sm1=0.6, M=0.05, gx=3.0, gy=-5.0, gz=7.0,
              cx1=40.0, cy1=-15.0, cz1=25.0, ax1=0.3, ay1=1.1, az1=-0.4, sc1=0.45,
              cx2=-12.0, cy2=33.0, cz2=8.0, ax2=-0.7, ay2=0.2, az2=0.9, sc2=1.0)


def _hat(xi):
    v, w = xi[:3], xi[3:]
    m = np.zeros((4, 4))
    m[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
    m[:3, 3] = v
    return m


@pytest.fixture(scope="module")
def template():
    """The segment template as a NumPy function of (q, sigma, h)."""
    names, exprs = X.template_outputs()
    fvals = X.f_values(sp.Symbol("s_"))
    f_fun = sp.lambdify(sp.Symbol("s_"), [fvals[k] for k in X.F.values()], "numpy")
    fun = sp.lambdify([X.th, X.ps, X.ta, X.sg, X.h, *X.F.values()], exprs, "numpy")

    def ev(q, sigma, h=2.0):
        s = sigma**2 * (q[0] ** 2 + q[1] ** 2 + q[2] ** 2)
        out = fun(*q, sigma, h, *[float(v) for v in f_fun(s)])
        return {n: float(v) for n, v in zip(names, out)}

    return ev


@pytest.mark.parametrize("q", [(0.3, -0.2, 0.5), (1e-9, 2e-9, -1e-9), (0.0, 0.0, 0.0), (2.0, 1.0, -1.5), (0.9, 0.0, 0.0)])
@pytest.mark.parametrize("sigma", [1.0, 0.37])
def test_segment_template_is_the_matrix_exponential_and_its_derivatives(template, q, sigma):
    """A and v against scipy's expm of sigma hat(Xi); omega_a and dv/dq_a against central differences."""
    h = 2.0

    def g(qq):
        return sl.expm(sigma * _hat(np.array([h, 0, 0, qq[2], qq[1], qq[0]])))

    t = template(q, sigma, h)
    A = np.array([t[f"A{i}"] for i in range(9)]).reshape(3, 3)
    v = np.array([t[f"v{i}"] for i in range(3)])
    assert np.abs(A - g(q)[:3, :3]).max() < 1e-14
    assert np.abs(v - g(q)[:3, 3]).max() < 1e-14
    e = 1e-6
    for a in range(3):
        dq = np.zeros(3)
        dq[a] = e
        gp, gm = g(np.add(q, dq)), g(np.subtract(q, dq))
        S = (gp[:3, :3] - gm[:3, :3]) / (2 * e) @ A.T
        om = np.array([S[2, 1], S[0, 2], S[1, 0]])
        assert np.abs(om - [t[f"Om{a}_{i}"] for i in range(3)]).max() < 1e-8
        assert np.abs((gp[:3, 3] - gm[:3, 3]) / (2 * e) - [t[f"dv{a}_{i}"] for i in range(3)]).max() < 1e-8


def test_with_psi_and_tau_zero_the_segment_is_the_papers_twist():
    """Xi_i = [L/n, 0, 0, 0, 0, theta_i] is the planar xi_i theta_i of Eq. (1)-(2) (symbolically)."""
    from esba.derive.kinematics import segment_twist

    n = sp.Symbol("n", positive=True)
    t = sp.Symbol("t", positive=True)
    planar = segment_twist(t, n) * t
    assert sp.simplify(X.segment_twist3d((t, 0, 0), n) - planar) == sp.zeros(6, 1)


def test_smooth_functions_are_exact_at_zero_and_across_the_switch():
    s = sp.Symbol("s_")
    for k0, values in ((1, (1, -1 / 6, 2 / 120)), (2, (1 / 2, -1 / 24, 2 / 720)), (3, (1 / 6, -1 / 120, 2 / 5040))):
        for order in range(3):
            f = sp.lambdify(s, X.smooth_f(k0, order, s), "numpy")
            assert f(0.0) == pytest.approx(values[order], rel=1e-15)
            assert f(1 - 1e-12) == pytest.approx(f(1 + 1e-12), rel=1e-10)


@pytest.fixture(scope="module")
def all_loads():
    """A small model with every load: n = 2, two payloads, a moment, two couples and gravity (generated here)."""
    from esba.derive.emit3d import generate_source3d

    eff = Effects3D.parse("air,axial,radial,fibres,payload:2,moment,couple:2,gravity")
    text, _ = generate_source3d(2, eff)
    return eff, _exec_source(text[text.index("import casadi"):])


def test_generated_gradient_and_hessian_match_finite_differences(all_loads):
    eff, f = all_loads
    p = [VALUES[k] for k in eff.parameters()]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = rng.normal(size=6) * 0.4
        q[:2] = np.abs(q[:2])
        g = np.asarray(f["gradient"](q, *p)).ravel()
        H = np.asarray(f["hessian"](q, *p))
        e = 1e-6
        eye = np.eye(6)
        gfd = np.array([(float(f["energy"](q + e * eye[i], *p)[0]) - float(f["energy"](q - e * eye[i], *p)[0])) / (2 * e) for i in range(6)])
        Hfd = np.array([(np.asarray(f["gradient"](q + e * eye[i], *p)).ravel() - np.asarray(f["gradient"](q - e * eye[i], *p)).ravel()) / (2 * e)
                        for i in range(6)])
        assert np.abs(g - gfd).max() < 1e-7 * np.abs(g).max()
        assert np.abs(H - Hfd).max() < 1e-7 * np.abs(H).max()
        assert np.array_equal(H, H.T)


def test_a_couple_is_two_dead_forces_on_an_arm_that_turns_with_the_section(all_loads):
    """The couple's energy is -f . (R(s) e - e), f = (m x e)/|e|^2, with R(s) the section's rotation:
    checked at the tip (s = 1) against the model's own tip rotation, at random states."""
    eff, f = all_loads
    p = [VALUES[k] for k in eff.parameters()]
    m, e = np.array([VALUES["cx2"], VALUES["cy2"], VALUES["cz2"]]), np.array([VALUES["ax2"], VALUES["ay2"], VALUES["az2"]])
    force = np.cross(m, e) / (e @ e)
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = rng.normal(size=6) * 0.8
        terms = np.asarray(f["energy"](q, *p)[1]).ravel()
        R = np.asarray(f["kinematics"](q, VALUES["L"])[1])
        expected = -force @ (R @ e - e)
        assert abs(terms[list(eff.terms()).index("couple2")] - expected) < 1e-12 * (1 + abs(expected))
    # at the straight state the moment of the two forces is m (e perpendicular to m)
    e = np.array([0.0, 1.0, 0.0])
    m = np.array([5.0, 0.0, -3.0])
    assert np.allclose(np.cross(e, np.cross(m, e) / (e @ e)), m)


def test_committed_3d_models_are_listed_with_this_derivation():
    data = json.loads((GENERATED_DIR / "manifest3d.json").read_text())
    from esba.derive.emit3d import COMMITTED_3D
    from esba.derive.effects3d import model3d_filename

    assert sorted(data["models"]) == sorted(model3d_filename(n, Effects3D.parse(e), v) for n, e, v in COMMITTED_3D)
    for name, entry in data["models"].items():
        assert entry["source_sha256"] == source_hash_3d(), f"stale 3-D model {name}: run `esba generate --refresh`"
        assert "DO NOT MODIFY BY HAND" in (GENERATED_DIR / name).read_text()[:200]


@pytest.mark.slow
@pytest.mark.ci
def test_committed_3d_models_are_fresh(tmp_path):
    """Regenerate every committed 3-D model: the bytes must match (else `esba generate --refresh`)."""
    from esba.derive.emit3d import refresh3d

    paths = refresh3d(tmp_path)
    stale = [p.name for p in paths if p.read_bytes() != (GENERATED_DIR / p.name).read_bytes()]
    assert not stale, f"stale 3-D models (run `esba generate --refresh`): {stale}"


@pytest.mark.parametrize("text, message", [
    ("air,wind", "unknown effect 'wind'"),
    ("payload:0", "a count must be at least 1"),
    ("payload:17", "payloads=17: expected an integer from 0 to 16"),
])
def test_bad_3d_effects_are_named(text, message):
    with pytest.raises(EffectError, match=message):
        Effects3D.parse(text)
