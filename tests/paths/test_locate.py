"""Locating special points: folds by the extended system and by Brent's method agree to 1e-8, a
branch point lands on its closed form, a value is met exactly, and each special point carries its
critical mode."""

from __future__ import annotations

import numpy as np
import pytest

from esba.analysis.path_analysis import column_buckling_load
from esba.model.scene import Payload, Scene
from esba.paths.continuation import PathOptions, trace
from esba.paths.corrector import Corrector
from esba.paths.locate import classify_branch_point, locate_value
from esba.paths.problem import PathProblem
from esba.statics.equilibrium import solve
from tests.tolerances import LOCATE_RTOL


@pytest.fixture(scope="module")
def pressure_branch():
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    problem = PathProblem.from_scene(scene, "pressure")
    return problem, solve(scene).theta


def test_a_fold_by_the_extended_system_and_by_bisection(pressure_branch):
    problem, start = pressure_branch
    ext = trace(problem, start, 0.0, to=0.3)
    bis = trace(problem, start, 0.0, to=0.3, options=PathOptions(locate="bisection"))
    assert len(ext.folds) == len(bis.folds) == 2
    for a, b in zip(ext.folds, bis.folds):
        assert a.status == b.status == "converged"
        assert a.method.startswith("extended system") and b.method.startswith("eigenvalue bisection")
        assert a.lam == pytest.approx(b.lam, rel=LOCATE_RTOL)


def test_a_fold_carries_its_critical_mode(pressure_branch):
    problem, start = pressure_branch
    for fold in trace(problem, start, 0.0, to=0.3).folds:
        g, h, _ = problem.ghl(fold.theta, fold.lam)
        assert np.max(np.abs(g)) < 1e-9
        v = fold.eigenvector
        assert np.linalg.norm(v) == pytest.approx(1.0) and v[np.argmax(np.abs(v))] > 0  # the sign convention
        np.testing.assert_allclose(h @ v, fold.eigenvalue * v, atol=1e-6 * np.max(np.abs(h)))
        assert abs(fold.eigenvalue) < 1e-8 * np.max(np.abs(np.linalg.eigvalsh(h)))
        assert fold.bracket[0] != fold.bracket[1]


@pytest.mark.parametrize("n", [2, 5])
def test_a_branch_point_lands_on_the_closed_form_buckling_load(n):
    f_cr = column_buckling_load(segments=n)
    problem = PathProblem.from_scene(Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=n), "payload")
    (bp,) = trace(problem, np.zeros(n), 0.5 * f_cr, to=1.5 * f_cr).branch_points
    assert bp.lam == pytest.approx(f_cr, rel=LOCATE_RTOL)
    assert bp.method.startswith("extended system (g + mu phi")
    assert (bp.morse_before, bp.morse_after) == (0, 1)


def test_a_value_is_met_exactly_between_two_points(pressure_branch):
    problem, start = pressure_branch
    corr = Corrector.for_trace(problem, 0.0, 0.3)
    a = corr.at_lambda(start, 0.0)
    a.tangent = corr.tangent(a, None, 1.0)
    b = corr.on_segment(a, 0.2)
    b.tangent = corr.tangent(b, a.tangent)
    target = 0.5 * (a.lam + b.lam)
    pt = locate_value(corr, a, b, 0.2, lambda p: p.lam - target)
    assert pt is not None and pt.lam == pytest.approx(target, abs=1e-14)
    assert np.max(np.abs(problem.ghl(pt.theta, pt.lam)[0])) < 1e-9


class _Quartic:
    """U = th2^2 / 2 - lam th1^2 / 2 + a th1^3 / 3 + b th1^2 th2 + th1^4 / 4: a branch point at 0 with the
    null vector (1, 0) and c = d3U[phi, phi, phi] = 2 a."""

    def __init__(self, a: float, b: float):
        self.a, self.b = a, b

    def ghl(self, theta, lam):
        t1, t2 = theta
        a, b = self.a, self.b
        g = np.array([-lam * t1 + a * t1**2 + 2 * b * t1 * t2 + t1**3, t2 + b * t1**2])
        h = np.array([[-lam + 2 * a * t1 + 2 * b * t2 + 3 * t1**2, 2 * b * t1], [2 * b * t1, 1.0]])
        return g, h, np.array([-t1, 0.0])

    def fold_terms(self, theta, lam, v):
        t1, _ = theta
        a, b = self.a, self.b
        hv_t = np.array([[(2 * a + 6 * t1) * v[0] + 2 * b * v[1], 2 * b * v[0]], [2 * b * v[0], 0.0]])
        return self.ghl(theta, lam)[1] @ v, hv_t, np.array([-v[0], 0.0]), 0.0


@pytest.mark.parametrize("a, b, kind", [(0.0, 0.0, "pitchfork"), (0.0, 1.0, "pitchfork"), (1.0, 0.0, "transcritical"), (0.5, 1.0, "transcritical")])
def test_branch_points_are_classified_by_the_cubic_term(a, b, kind):
    got, cubic = classify_branch_point(_Quartic(a, b), np.zeros(2), 0.0, np.array([1.0, 0.0]))
    assert got == kind and cubic == pytest.approx(2 * a)
