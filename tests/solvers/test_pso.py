"""The particle swarm (esba.solvers.pso) on problems with known optima, its constraints and its history."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.solvers.pso import CLERC_KENNEDY, PSOOptions, PSOOptionsError, minimize

#: PSO on a smooth 2-D problem with 30 particles converges to round-off of the objective; the
#: positions to about sqrt(objective round-off) where the optimum is a smooth minimum.
POSITION_TOL = 1e-4


def shifted_sphere(X):
    return (X[:, 0] - 1.0) ** 2 + (X[:, 1] - 2.0) ** 2


def test_defaults_are_the_papers_and_clerc_kennedys():
    o = PSOOptions()
    assert (o.particles, o.iterations) == (30, 50)
    assert (o.inertia, o.cognitive, o.social) == CLERC_KENNEDY == (0.7298, 1.49618, 1.49618)
    # the constriction factor chi = 2 / |2 - phi - sqrt(phi^2 - 4 phi)| with phi = 4.1, and c = chi * phi / 2
    phi = 4.1
    chi = 2.0 / abs(2.0 - phi - math.sqrt(phi * phi - 4.0 * phi))
    assert o.inertia == pytest.approx(chi, abs=1e-4)
    assert o.cognitive == pytest.approx(chi * phi / 2, abs=1e-4)


def test_unconstrained_minimum():
    r = minimize(shifted_sphere, [-5, -5], [5, 5], options=PSOOptions(iterations=100))
    assert r.feasible
    np.testing.assert_allclose(r.x, [1.0, 2.0], atol=POSITION_TOL)
    assert r.fun < 1e-8


def test_linear_constraint_optimum_on_the_boundary():
    # min (x-1)^2 + (y-2)^2 with x + y <= 2: the projection of (1, 2) on the line, (0.5, 1.5)
    seen = []

    def f(X):
        seen.append(X.copy())
        return shifted_sphere(X)

    r = minimize(f, [0, 0], [3, 3], linear=([[1.0, 1.0]], [2.0]), options=PSOOptions(seed=3, iterations=80))
    np.testing.assert_allclose(r.x, [0.5, 1.5], atol=POSITION_TOL)
    assert r.fun == pytest.approx(0.5, abs=1e-8)
    # the objective never saw a point outside the box or the linear constraint
    pts = np.concatenate(seen)
    assert np.all(pts.sum(axis=1) <= 2.0 + 1e-12)
    assert np.all((pts >= 0.0) & (pts <= 3.0))


def test_nonlinear_constraint_by_feasibility_rules():
    # min (x-2)^2 + (y-2)^2 with x^2 + y^2 <= 1: optimum (1, 1) / sqrt(2)
    def f(X):
        return shifted_sphere(X + np.array([-1.0, 0.0])), np.maximum(0.0, (X**2).sum(axis=1) - 1.0)

    r = minimize(f, [-2, -2], [2, 2], options=PSOOptions(seed=5, iterations=100))
    assert r.feasible and r.violation == 0.0
    # a curved boundary is approached from the feasible side only: slower along it than a wall
    assert r.fun == pytest.approx((2.0 * math.sqrt(2.0) - 1.0) ** 2, rel=1e-3)
    np.testing.assert_allclose(r.x, [math.sqrt(0.5)] * 2, atol=1e-2)


def test_failed_evaluations_never_become_the_best():
    # the objective is nan on x > 0.5, where the unconstrained minimum (1, 2) lies
    def f(X):
        return np.where(X[:, 0] > 0.5, np.nan, shifted_sphere(X))

    r = minimize(f, [-3, -3], [3, 3], options=PSOOptions(seed=1, iterations=80))
    assert r.x[0] <= 0.5
    np.testing.assert_allclose(r.x, [0.5, 2.0], atol=1e-3)
    assert np.isnan(r.history.values).any()


def test_infeasible_everywhere_reports_the_least_violating_point():
    def f(X):
        return X[:, 0], 1.0 + (X[:, 1] - 0.25) ** 2  # never satisfied; least violation at y = 0.25

    r = minimize(f, [0, 0], [1, 1], options=PSOOptions(seed=0, iterations=60))
    assert not r.feasible
    assert r.violation == pytest.approx(1.0, abs=1e-8)
    assert r.x[1] == pytest.approx(0.25, abs=1e-3)
    assert np.all(np.isinf(r.history.best_value))


def test_same_seed_same_run_other_seed_other_run():
    o = PSOOptions(seed=42, iterations=10)
    a = minimize(shifted_sphere, [-5, -5], [5, 5], options=o)
    b = minimize(shifted_sphere, [-5, -5], [5, 5], options=o)
    c = minimize(shifted_sphere, [-5, -5], [5, 5], options=PSOOptions(seed=43, iterations=10))
    np.testing.assert_array_equal(a.history.positions, b.history.positions)
    np.testing.assert_array_equal(a.x, b.x)
    assert not np.array_equal(a.history.positions, c.history.positions)


@pytest.mark.parametrize("particles, iterations, dims", [(30, 50, 2), (7, 3, 3)])
def test_history_shapes_and_one_call_per_iteration(particles, iterations, dims):
    calls = []

    def f(X):
        calls.append(len(X))
        return (X**2).sum(axis=1)

    r = minimize(f, [-1] * dims, [1] * dims, options=PSOOptions(particles=particles, iterations=iterations))
    h = r.history
    assert h.positions.shape == (iterations + 1, particles, dims)
    assert h.values.shape == h.violations.shape == (iterations + 1, particles)
    assert h.best_value.shape == (iterations + 1,)
    assert h.best_position.shape == (iterations + 1, dims)
    assert calls == [particles] * (iterations + 1)  # the whole swarm in one call
    assert r.calls == iterations + 1 and r.evaluations == particles * (iterations + 1)
    assert np.all(np.diff(h.best_value) <= 0.0)  # the best never gets worse
    assert h.best_value[-1] == r.fun


def test_initial_swarm_is_random_in_the_box_and_feasible():
    r = minimize(shifted_sphere, [0, 0], [8, 8], linear=([[1.0, 1.0]], [8.0]), options=PSOOptions(particles=200, iterations=1, seed=7))
    x0 = r.history.positions[0]
    assert np.all(x0.sum(axis=1) <= 8.0)
    assert np.all(x0 >= 0.0)
    # spread over the triangle, not clustered: both coordinates cover most of their range
    assert np.ptp(x0[:, 0]) > 6.0 and np.ptp(x0[:, 1]) > 6.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"particles": 1}, "particles=1: expected a whole number from 2 to 500000"),
        ({"iterations": 0}, "iterations=0"),
        ({"inertia": -0.1}, "inertia=-0.1"),
        ({"cognitive": float("nan")}, "cognitive=nan"),
        ({"max_velocity": 0.0}, "max_velocity=0.0"),
        ({"seed": -1}, "seed=-1"),
        ({"seed": 1.5}, "seed=1.5"),
    ],
)
def test_bad_options_name_the_value(kwargs, message):
    with pytest.raises(PSOOptionsError, match=message.replace("(", r"\(").replace(")", r"\)")):
        PSOOptions(**kwargs)


def test_bad_bounds_and_constraints():
    with pytest.raises(PSOOptionsError, match="lower < upper"):
        minimize(shifted_sphere, [0, 1], [1, 1])
    with pytest.raises(PSOOptionsError, match="expected A of shape"):
        minimize(shifted_sphere, [0, 0], [1, 1], linear=([[1.0, 1.0, 1.0]], [1.0]))
    with pytest.raises(PSOOptionsError, match="no point inside the linear constraints"):
        minimize(shifted_sphere, [0, 0], [1, 1], linear=([[1.0, 1.0]], [-1.0]), options=PSOOptions(max_tries=5))
