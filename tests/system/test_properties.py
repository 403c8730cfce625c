"""Property-based tests over the parameter box, with hypothesis.

The box: r2 in [0.05, 7] mm with d up to r1 - r2 - 0.05 mm, rho in [0, 40] deg, P in [0, 0.2] MPa,
one payload of 0-3 N in any direction anywhere along the actuator, n in {1, 2, 3, 5, 8}. The
examples are derandomised, so a run is reproducible (and CI sees the same cases).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from esba.analysis.stiffness import tip_jacobian
from esba.model.scene import Actuator, Payload, Scene
from esba.statics.batch import BatchOptions, solve_scenes
from esba.statics.equilibrium import solve
from tests.tolerances import (
    BATCH_THETA_ATOL,
    EQUILIBRIUM_GRAD_ATOL,
    FD_ATOL,
    FD_RTOL,
    FD_STEP,
    KERNEL_ATOL,
    KERNEL_RTOL,
)

CHEAP = settings(max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
SOLVES = settings(max_examples=30, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def scenes(draw, pressure: bool = True):
    r1 = 8.0
    r2 = draw(st.floats(0.05, 7.0))
    d = draw(st.floats(0.0, 1.0)) * (r1 - r2 - 0.05)
    act = Actuator(r1=r1, r2=r2, d=d, rho_deg=draw(st.floats(0.0, 40.0)))
    load = Payload(draw(st.floats(0.0, 3.0)), draw(st.floats(0.0, 360.0)), draw(st.floats(0.05, 1.0)))
    n = draw(st.sampled_from([1, 2, 3, 5, 8]))
    return Scene(actuator=act, pressure=draw(st.floats(0.0, 0.2)), payloads=(load,), segments=n)


@st.composite
def points(draw):
    """A scene and angles inside the model's domain (at least half-way from its lower bound)."""
    scene = draw(scenes())
    model = scene.model()
    lo = model.lower_bounds(scene.parameters(scene.pressure))
    frac = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=scene.segments, max_size=scene.segments)))
    theta = 0.5 * lo + frac * (1.5 - 0.5 * lo)  # from lo/2 (lo < 0) to 1.5 rad
    return scene, theta


def _model_and_params(scene):
    model = scene.model()
    return model, model.param_vector(scene.parameters(scene.pressure))


def _fd(f, theta, lo):
    """Fourth-order central differences of f at theta, column j = df/dtheta_j.

    The step is FD_STEP, cut to 2 % of the distance to the domain's lower bound: near it the
    square root of Eq. (10) curves fast, and a fixed step would measure its own truncation error.
    """
    cols = []
    for j in range(len(theta)):
        h = min(FD_STEP, 0.02 * (theta[j] - lo[j]))
        e = np.zeros(len(theta))
        e[j] = h
        cols.append((-f(theta + 2 * e) + 8 * f(theta + e) - 8 * f(theta - e) + f(theta - 2 * e)) / (12 * h))
    return np.array(cols)


@CHEAP
@given(points())
def test_gradient_matches_finite_differences(point):
    scene, theta = point
    model, pv = _model_and_params(scene)
    g = model.gradient(theta, pv)
    g_fd = _fd(lambda t: model.energy(t, pv), theta, model.lower_bounds(scene.parameters(scene.pressure)))
    np.testing.assert_allclose(g, g_fd, rtol=FD_RTOL, atol=FD_ATOL)


@CHEAP
@given(points())
def test_hessian_is_symmetric_and_matches_the_gradient(point):
    scene, theta = point
    model, pv = _model_and_params(scene)
    h = model.hessian(theta, pv)
    np.testing.assert_allclose(h, h.T, rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
    h_fd = _fd(lambda t: model.gradient(t, pv), theta, model.lower_bounds(scene.parameters(scene.pressure))).T
    np.testing.assert_allclose(h, h_fd, rtol=FD_RTOL, atol=FD_ATOL)


@SOLVES
@given(scenes())
def test_equilibrium_residual_below_tolerance(scene):
    """ok means stationary and stable; not ok means a message; never a NaN; the batch agrees."""
    r = solve(scene)
    assert np.all(np.isfinite(r.theta)) and np.all(np.isfinite(r.tip))
    if r.ok:
        assert r.gradient_norm <= EQUILIBRIUM_GRAD_ATOL
        assert r.eigenvalues[0] > 0
    else:
        assert r.message
    b = solve_scenes([scene], BatchOptions(compile="never"))
    assert bool(b.ok[0]) == r.ok
    if r.ok:
        np.testing.assert_allclose(b.theta[0], r.theta, atol=BATCH_THETA_ATOL)


def _predicted_tip_change(r, dF: float) -> np.ndarray:
    """Linear response of the tip to dF more payload: J dtheta, H dtheta = -(dg/dF) dF (g is linear in F)."""
    model = r.model
    values = r.parameters
    at0 = dict(values, F1=0.0)
    at1 = dict(values, F1=1.0)
    dg = model.gradient(r.theta, model.param_vector(at1)) - model.gradient(r.theta, model.param_vector(at0))
    dtheta = -np.linalg.solve(model.hessian(r.theta, model.param_vector(values)), dg) * dF
    return tip_jacobian(model, r.theta, values["L"]) @ dtheta


@SOLVES
@given(scenes())
def test_results_continuous_in_the_payload(scene):
    """A little more payload moves the tip by about the linear response, or the path's jump is noted."""
    dF = 0.01
    a = solve(scene)
    b = solve(scene.replace(payloads=(scene.payloads[0].scaled(1.0 + dF / max(scene.payloads[0].force, 1e-9)),)))
    if not (a.ok and b.ok) or a.notes or b.notes:
        assert (a.message or a.ok) and (b.message or b.ok)  # said, not hidden
        return
    moved = np.linalg.norm(b.tip[:2] - a.tip[:2])
    predicted = np.linalg.norm(_predicted_tip_change(a, b.scene.payloads[0].force - a.scene.payloads[0].force))
    assert moved <= 2.0 * predicted + 1e-6, (moved, predicted)


@SOLVES
@given(scenes())
def test_results_continuous_in_the_pressure(scene):
    dP = 1e-4
    a = solve(scene)
    b = solve(scene.replace(pressure=scene.pressure + dP))
    if not (a.ok and b.ok) or a.notes or b.notes:
        assert (a.message or a.ok) and (b.message or b.ok)
        return
    # the same bound by the linear response: dtheta = -H^-1 dg/dP dP (g is linear in P)
    model, values = a.model, a.parameters
    dg = model.gradient(a.theta, model.param_vector(dict(values, P=1.0))) - model.gradient(a.theta, model.param_vector(dict(values, P=0.0)))
    dtheta = -np.linalg.solve(model.hessian(a.theta, model.param_vector(values)), dg) * dP
    predicted = np.linalg.norm(tip_jacobian(model, a.theta, values["L"]) @ dtheta)
    assert np.linalg.norm(b.tip[:2] - a.tip[:2]) <= 2.0 * predicted + 1e-6
    assert math.isfinite(b.energy)
