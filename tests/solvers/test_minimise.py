"""IPOPT on the generated model, the minimiser of record: it lands on the minimiser, stays inside the
model's domain, accepts an equilibrium at once when started there, and its polish reaches round-off."""

from __future__ import annotations

import numpy as np
import pytest

from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.solvers.minimise import WARM_MU_INIT, ipopt_solver, minimise, polish
from tests.tolerances import EQUILIBRIUM_GRAD_ATOL


@pytest.fixture(scope="module")
def setting():
    model = MAIN_JOB.model()
    values = MAIN_JOB.parameters(0.1238739)
    return model, model.param_vector(values), model.lower_bounds(values)


def test_ipopt_lands_on_a_stable_minimiser(setting):
    model, pv, lbx = setting
    m = minimise(model, np.zeros(3), pv, lbx)
    assert m.success and m.status == "Solve_Succeeded" and m.iterations > 0
    g, h = model.gradient(m.theta, pv), model.hessian(m.theta, pv)
    assert np.max(np.abs(g)) < 1e-10 and np.linalg.eigvalsh(h)[0] > 0
    assert np.all(m.theta > lbx)


def test_a_warm_start_at_the_minimiser_takes_no_iteration(setting):
    model, pv, lbx = setting
    first = minimise(model, np.zeros(3), pv, lbx)
    again = minimise(model, first.theta, pv, lbx, warm=True)
    assert again.success and again.iterations == 0
    np.testing.assert_allclose(again.theta, first.theta, atol=1e-12)


def test_polish_brings_stationarity_to_round_off(setting):
    model, pv, lbx = setting
    exact = minimise(model, np.zeros(3), pv, lbx).theta
    rough = exact + 1e-5
    polished = polish(model, rough, pv, lbx, steps=4)
    assert np.max(np.abs(model.gradient(polished, pv))) < 1e-11 < np.max(np.abs(model.gradient(rough, pv)))


def test_a_start_below_the_domain_is_moved_inside(setting):
    model, pv, lbx = setting
    m = minimise(model, lbx - 1.0, pv, lbx)
    assert m.success and np.all(m.theta > lbx)


def test_solvers_are_built_once_per_model_and_setting(setting):
    model, _, _ = setting
    assert ipopt_solver(model) is ipopt_solver(model)
    assert ipopt_solver(model, warm=True) is not ipopt_solver(model)
    assert WARM_MU_INIT < 1e-8


def test_a_loaded_scene_is_stationary_within_the_solvers_tolerance():
    scene = Scene(pressure=0.15, payloads=(Payload(1.0, 45.0),), segments=5)
    model = scene.model()
    values = scene.parameters(0.15)
    m = minimise(model, np.full(5, 0.1), model.param_vector(values), model.lower_bounds(values))
    assert m.success and np.max(np.abs(model.gradient(m.theta, model.param_vector(values)))) <= EQUILIBRIUM_GRAD_ATOL
