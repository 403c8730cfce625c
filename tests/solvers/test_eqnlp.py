"""The equilibrium-constrained NLP builder that design, fit and the pressure for a target share."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.model.closed_form import pressure_for_angle
from esba.model.generated import load_model
from esba.model.scene import Scene
from esba.solvers.eqnlp import EquilibriumNLP, model_gradient

TABLE1 = dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=math.radians(10.0), E=0.54)


def test_the_pressure_of_a_target_angle_is_the_closed_form():
    m = load_model(3, "air,axial,radial,fibres")
    b = EquilibriumNLP("t")
    theta = b.variable("theta", 3)
    P = b.variable("P", lb=0.0, lower=("min_pressure", "P >= 0", "MPa"))
    b.equilibrium(model_gradient(m, theta, dict(TABLE1, P=P)), "unloaded")
    b.constraint(theta[0] + theta[1] + theta[2] - math.pi / 2, "angle", "total angle 90 deg", "rad", 0.0, 0.0)
    nlp = b.build(P)
    sol = nlp.solve(nlp.x0(theta=[0.5, 0.5, 0.5], P=0.1))
    assert sol.success
    assert float(sol["P"][0]) == pytest.approx(pressure_for_angle(Scene(payloads=()), 90.0), rel=1e-8)
    np.testing.assert_allclose(sol["theta"], np.full(3, math.pi / 6), atol=1e-8)
    assert [c.name for c in nlp.constraints][:3] == ["equilibrium_unloaded[0]", "equilibrium_unloaded[1]", "equilibrium_unloaded[2]"]


def test_parameters_change_between_solves_of_one_solver():
    m = load_model(3, "air,axial,radial,fibres")
    b = EquilibriumNLP("p")
    theta = b.variable("theta", 3)
    P = b.parameter("P")
    b.equilibrium(model_gradient(m, theta, dict(TABLE1, P=P)), "state")
    nlp = b.build(ca_zero := 0 * theta[0])
    del ca_zero
    angles = []
    for p in (0.05, 0.1):
        sol = nlp.solve(nlp.x0(theta=[0.2, 0.2, 0.2]), nlp.p(P=p))
        assert sol.success
        angles.append(float(np.sum(sol["theta"])))
    assert angles[1] > angles[0] > 0
    with pytest.raises(KeyError, match="'P' missing"):
        nlp.p()


def test_an_active_bound_is_reported_with_its_multiplier():
    m = load_model(3, "air,axial,radial,fibres")
    b = EquilibriumNLP("bound")
    theta = b.variable("theta", 3)
    P = b.variable("P", lb=0.0, ub=0.05, upper=("max_pressure", "P <= 0.05 MPa", "MPa"))
    b.equilibrium(model_gradient(m, theta, dict(TABLE1, P=P)), "state")
    nlp = b.build(-(theta[0] + theta[1] + theta[2]))  # bend as far as allowed: the pressure bound holds
    sol = nlp.solve(nlp.x0(theta=[0.1, 0.1, 0.1], P=0.01))
    active = nlp.active(sol.x, sol.g, sol.lam_g, sol.lam_x, 1e-6, 1.0)
    assert [a.name for a in active] == ["max_pressure"] and active[0].value == pytest.approx(0.05)
    assert active[0].multiplier is not None and active[0].multiplier > 0


def test_domain_constraints_and_bad_blocks():
    b = EquilibriumNLP("d")
    theta = b.variable("theta", 2)
    b.domain(theta, 135.0, 8.0, 3.0, 4.0, "s")
    assert [c.name for c in b._constraints] == ["domain_sqrt[0]", "domain_denominator[0]", "domain_sqrt[1]", "domain_denominator[1]"]
    with pytest.raises(ValueError, match="defined twice"):
        b.variable("theta", 2)
    with pytest.raises(KeyError, match="needs parameters"):
        model_gradient(load_model(3), theta, {"L": 135.0})
