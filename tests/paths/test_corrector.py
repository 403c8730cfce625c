"""The corrector: the compiled O(n) bordered Newton against the dense one, the Morse index from
pivots against the eigenvalues, tangents, the metric, and the fallback next to a singular Hessian."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.analysis.path_analysis import column_buckling_load
from esba.model.scene import Payload, Scene
from esba.paths.corrector import Corrector, Settings, pivot_morse
from esba.paths.problem import PathProblem
from tests.tolerances import EQUILIBRIUM_GRAD_ATOL, QUADRATIC_CONSTANT


@pytest.fixture(scope="module")
def problem():
    return PathProblem.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure")


@pytest.mark.parametrize("n", [1, 3, 8])
def test_compiled_and_dense_correctors_land_on_the_same_point(n):
    problem = PathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(1.5, 60.0),), segments=n), "payload")
    corr = Corrector.for_trace(problem, 0.0, 3.0)
    c = np.zeros(n + 1)
    c[-1] = 1.0
    x0 = np.concatenate([np.full(n, 0.3 / n), [1.5]])
    fast = corr.correct(x0, c, 1.5)
    dense = corr.correct(x0, c, 1.5, dense=True)
    assert fast is not None and dense is not None
    np.testing.assert_allclose(fast.theta, dense.theta, atol=1e-11)
    assert fast.lam == dense.lam == 1.5
    assert np.max(np.abs(problem.ghl(fast.theta, fast.lam)[0])) <= EQUILIBRIUM_GRAD_ATOL
    # Newton converges quadratically: r_{k+1} <= C r_k^2
    r = [x for x in fast.residuals if x > 1e-9]
    assert all(b <= QUADRATIC_CONSTANT * a * a for a, b in zip(r, r[1:]))


def test_the_morse_index_of_the_pivots_is_the_eigenvalues(problem):
    corr = Corrector.for_trace(problem, 0.0, 0.3)
    start = corr.at_lambda(np.zeros(3), 0.0)
    start.tangent = corr.tangent(start, None, 1.0)
    pt = start
    seen = set()
    for _ in range(80):  # along the branch through both folds: Morse 0, 1, 0
        nxt = corr.on_segment(pt, 0.05)
        assert nxt is not None
        nxt.tangent = corr.tangent(nxt, pt.tangent)
        eig = np.linalg.eigvalsh(problem.ghl(nxt.theta, nxt.lam)[1])
        assert nxt.morse == int(np.sum(eig < -1e-9 * np.max(np.abs(eig))))
        assert math.copysign(1.0, nxt.min_pivot) == math.copysign(1.0, eig[0])
        seen.add(nxt.morse)
        pt = nxt
        if pt.lam > 0.3:
            break
    assert seen == {0, 1}


def test_tangents_are_unit_and_oriented(problem):
    corr = Corrector.for_trace(problem, 0.0, 0.3)
    a = corr.at_lambda(np.zeros(3), 0.05)
    t = corr.tangent(a, None, 1.0)
    assert corr.norm(t) == pytest.approx(1.0) and t[-1] > 0
    _, h, gl = problem.ghl(a.theta, a.lam)
    np.testing.assert_allclose(h @ t[:-1] + gl * t[-1], 0.0, atol=1e-9)
    back = corr.tangent(a, -t)
    np.testing.assert_allclose(back, -t, atol=1e-12)
    # the dense bordered solve gives the same tangent
    np.testing.assert_allclose(corr._tangent_dense(a, t, 1.0), t, atol=1e-12)


def test_the_metric_weights_the_angles_by_n_and_lambda_by_its_scale(problem):
    corr = Corrector(problem, Settings(), w=3.0, sigma=0.5)
    a = np.array([1.0, 0.0, 0.0, 0.5])
    assert corr.dot(a, a) == pytest.approx(3.0 + 1.0)
    np.testing.assert_allclose(corr.row(a), [3.0, 0.0, 0.0, 2.0])
    assert Corrector.for_trace(problem, 0.0, 2.0).sigma == 2.0
    assert Corrector.for_trace(problem, 0.0, math.inf).sigma == problem.scale


def test_next_to_a_branch_point_both_correctors_find_the_same_equilibrium():
    """The straight column just below its buckling load, started off the axis: H is nearly singular,
    the block elimination loses digits, and the compiled and the dense corrector still land on the
    same equilibrium (the bent branch that crosses the straight one there) to 1e-9 rad."""
    f_cr = column_buckling_load(segments=3)
    problem = PathProblem.from_scene(Scene(pressure=0.0, payloads=(Payload(f_cr, 180.0),)), "payload")
    corr = Corrector.for_trace(problem, 0.0, 2 * f_cr)
    lam = f_cr * (1 - 1e-6)
    x0 = np.concatenate([np.full(3, 1e-4), [lam]])
    c = np.zeros(4)
    c[-1] = 1.0
    fast, dense = corr.correct(x0, c, lam), corr.correct(x0, c, lam, dense=True)
    assert fast is not None and dense is not None and fast.small_pivot < 1e-5
    np.testing.assert_allclose(fast.theta, dense.theta, atol=1e-9)
    for pt in (fast, dense):
        assert np.max(np.abs(problem.ghl(pt.theta, pt.lam)[0])) <= EQUILIBRIUM_GRAD_ATOL


def test_pivot_morse_counts_negative_pivots_beyond_the_critical_band():
    assert pivot_morse(np.array([2.0, -1.0, 3.0])) == (1, -1.0 / 3.0)
    assert pivot_morse(np.array([2.0, -1e-12, 3.0]))[0] == 0
