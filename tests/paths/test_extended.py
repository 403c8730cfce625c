"""The engine for curves of an extended system (esba.paths.extended) on a closed form: a circle."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from esba.paths.extended import Node, correct, follow, tangent


class Circle:
    """x^2 + y^2 = r^2 (one equation, two unknowns); tests: x and y (zero at the four axis points)."""

    def __init__(self, r: float):
        self.r = r

    def evaluate(self, u, anchor):
        return np.array([u @ u - self.r**2]), 2.0 * u[None, :], None

    def converged(self, res, data):
        return abs(res[0]) <= 1e-13

    def acceptable(self, res, data):
        return abs(res[0]) <= 1e-10

    def anchor(self, u):
        return u

    def tests(self, node):
        return np.array([node.u[0], node.u[1]])


@dataclass(frozen=True)
class Options:
    ds: float = 0.1
    ds_min: float = 1e-8
    ds_max: float = 0.2
    max_steps: int = 500
    max_iterations: int = 10


def test_a_closed_curve_is_followed_round_and_its_axis_points_located():
    system = Circle(2.0)
    start = correct(system, np.array([1.5, 1.2]), np.array([1.0, 0.0]), 1.5, 10)  # at x = 1.5
    assert start is not None and start.u[1] == pytest.approx(np.sqrt(4 - 1.5**2), rel=1e-14)

    def stop(nodes, ds):
        back = len(nodes) > 5 and np.linalg.norm(nodes[-1].u - start.u) < 0.6 * ds
        return ("closed", False) if back else ("", False)

    nodes, crossings, why = follow(system, start, 1.0, Options(), stop)
    assert why == "closed"
    # the four points where the circle crosses an axis, each to round-off, in the order met
    assert len(crossings) == 4 and all(c.status == "converged" for c in crossings)
    for c in crossings:
        assert abs(c.node.u[c.index]) < 1e-13 and np.linalg.norm(c.node.u) == pytest.approx(2.0, rel=1e-14)
    # the arclength (the corrector's, a chord sum) reaches 2 pi r
    s = [c.arclength for c in crossings]
    assert s == sorted(s) and s[-1] < 4 * np.pi


def test_tangent_is_the_null_vector_oriented_along_the_previous():
    system = Circle(1.0)
    node = Node(np.array([1.0, 0.0]), None)
    t = tangent(system, node, np.array([0.0, -1.0]))
    assert np.allclose(t, [0.0, -1.0], atol=1e-15)
