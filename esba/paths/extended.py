"""Pseudo-arclength continuation of an extended system: curves of special points in two parameters.

A fold of a branch (:mod:`esba.paths.locate`) solves an *extended system*: g = 0 with H v = 0 and
a normalisation of v. With one more free parameter its solutions form a curve (codimension-two
continuation: AUTO-07p's LP continuation, BifurcationKit's fold continuation), and this module
follows such a curve for any system F(u) = 0 of m - 1 equations in m unknowns that says what it is
(:class:`ExtendedSystem`): its residual and Jacobian at u (the anchor is where the correction
started, for normalisations such as v0 . v = 1 with v0 the anchor's v), when a point counts as
converged, the test functions whose zeros are the curve's special points, and when to stop.

The engine is the one of branches, on a dense system: a tangent predictor, Newton on the
bordered system [[dF/du], [t]] (the pseudo-arclength condition t . (u - u_a) = s), an adaptive
step (grown after an easy corrector, halved after a failed one or a sharp turn), and every sign
change of a test function located by Brent's method on the arclength (each trial point a
converged point of the curve), as :mod:`esba.paths.locate` locates a fold between two points of a
branch. :mod:`esba.analysis.folds` builds the fold system of two scene parameters on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Protocol, Sequence

import numpy as np

__all__ = ["ExtendedSystem", "Node", "Crossing", "correct", "tangent", "on_segment", "locate_zero", "follow"]


class ExtendedSystem(Protocol):
    """What :func:`follow` needs of a system F(u) = 0 (m - 1 equations, m unknowns)."""

    def evaluate(self, u: np.ndarray, anchor: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any] | None:
        """(residual, Jacobian (m - 1) x m, data) at u, or None where the system is not defined."""

    def converged(self, residual: np.ndarray, data: Any) -> bool:
        """The residual is at the system's tolerance."""

    def acceptable(self, residual: np.ndarray, data: Any) -> bool:
        """Near enough to converged to accept where Newton stagnates at round-off."""

    def anchor(self, u: np.ndarray) -> np.ndarray:
        """The start of a correction made ready (e.g. v normalised): it is also the anchor."""

    def tests(self, node: Node) -> np.ndarray:
        """The test functions at a converged point (their sign changes are the special points)."""


class Node:
    """A converged point of the curve: u, its unit tangent t (when computed), the system's data, the corrector's iterations."""

    __slots__ = ("u", "t", "data", "iterations")

    def __init__(self, u: np.ndarray, data: Any, iterations: int = 0):
        self.u = u
        self.t: np.ndarray | None = None
        self.data = data
        self.iterations = iterations


@dataclass(frozen=True)
class Crossing:
    """A zero of test function ``index`` between two points: the point (``converged``: Brent's root on
    the curve; ``guess``: the end with the smaller test value) and its arclength from the start."""

    index: int
    node: Node
    status: str
    arclength: float


def correct(system: ExtendedSystem, u: np.ndarray, row: np.ndarray, c0: float, max_iterations: int) -> Node | None:
    """Newton on F(u) = 0 and row . u = c0 from u; None when it fails (leaves the system's domain,
    is not finite, grows, or needs more than ``max_iterations``)."""
    u = system.anchor(np.asarray(u, dtype=float))
    anchor = u.copy()
    previous = math.inf
    for it in range(max_iterations + 1):
        out = system.evaluate(u, anchor)
        if out is None:
            return None
        res, jac, data = out
        r_row = float(row @ u - c0)
        if system.converged(res, data) and abs(r_row) <= 1e-13 * (1.0 + abs(c0)):
            return Node(u, data, it)
        if it == max_iterations:
            return None
        size = float(np.max(np.abs(res)))
        if it >= 2 and size > 2.0 * previous:
            return None
        previous = size
        try:
            step = np.linalg.solve(np.vstack([jac, row]), -np.concatenate([res, [r_row]]))
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(step)):
            return None
        u = u + step
        if float(np.max(np.abs(step))) <= 1e-15 * (1.0 + float(np.max(np.abs(u)))):  # round-off: accept if nearly converged
            out = system.evaluate(u, anchor)
            if out is None or not system.acceptable(out[0], out[2]):
                return None
            return Node(u, out[2], it + 1)
    return None  # pragma: no cover


def tangent(system: ExtendedSystem, node: Node, previous: np.ndarray | None) -> np.ndarray | None:
    """The unit tangent at ``node``: the null vector of dF/du, oriented along ``previous`` (by the
    bordered system [[dF/du], [previous]] t = e_m), or by SVD when there is none."""
    out = system.evaluate(node.u, system.anchor(node.u.copy()))
    if out is None:
        return None
    jac = out[1]
    if previous is None:
        t = np.linalg.svd(jac)[2][-1]
    else:
        rhs = np.zeros(jac.shape[0] + 1)
        rhs[-1] = 1.0
        try:
            t = np.linalg.solve(np.vstack([jac, previous]), rhs)
        except np.linalg.LinAlgError:
            return None
    if not np.all(np.isfinite(t)):
        return None
    t = t / np.linalg.norm(t)
    if previous is not None and t @ previous < 0:
        t = -t
    return t


def on_segment(system: ExtendedSystem, a: Node, s: float, max_iterations: int) -> Node | None:
    """The point at arclength s along a's tangent (pseudo-arclength corrector)."""
    return correct(system, a.u + s * a.t, a.t, float(a.t @ a.u) + s, max_iterations)


class _Fail(Exception):
    pass


def locate_zero(system: ExtendedSystem, a: Node, s_b: float, f: Callable[[Node], float], f_a: float, f_b: float, max_iterations: int) -> Node | None:
    """The point of the curve between a (arclength 0) and s_b where f changes sign: Brent's method on
    the arclength, each trial a corrected point; None when a trial fails."""
    from scipy.optimize import brentq  # SciPy's optimize takes ~0.2 s to import: only when a point is located

    cache: dict[float, Node | None] = {}

    def value(s: float) -> float:
        if s == 0.0:
            return f_a
        if s == s_b:
            return f_b
        if s not in cache:
            cache[s] = on_segment(system, a, s, max_iterations)
        node = cache[s]
        if node is None:
            raise _Fail
        return f(node)

    try:
        s_star = brentq(value, 0.0, s_b, xtol=1e-15, rtol=1e-15, maxiter=200)
    except (_Fail, ValueError, RuntimeError):
        return None
    return cache.get(s_star) or on_segment(system, a, s_star, max_iterations)


def follow(
    system: ExtendedSystem,
    start: Node,
    direction: float,
    options: Any,
    stop: Callable[[Sequence[Node], float], tuple[str, bool]],
) -> tuple[list[Node], list[Crossing], str]:
    """Follow the curve from ``start`` one way (``direction`` +1 or -1 along the SVD tangent).

    ``options`` gives ``ds``, ``ds_min``, ``ds_max``, ``max_steps``, ``max_iterations``;
    ``stop(nodes, ds)`` says after each accepted point why to stop (empty: go on) and whether the last
    point goes (it overlaps something already traced). Returns the points, the zeros of the test
    functions between them, and why the curve ended.
    """
    nodes = [start]
    crossings: list[Crossing] = []
    t0 = tangent(system, start, None)
    if t0 is None:
        return nodes, crossings, "no tangent at the start"
    start.t = t0 * direction
    ds = options.ds
    s_total = 0.0
    a = start
    tests_a = system.tests(a)
    for _ in range(options.max_steps):
        b = on_segment(system, a, ds, options.max_iterations)
        ok = b is not None
        if ok:
            b.t = tangent(system, b, a.t)
            ok = b.t is not None and float(b.t @ a.t) > 0.95  # a sharp turn: a smaller step
        if not ok:
            ds *= 0.5
            if ds < options.ds_min:
                return nodes, crossings, "the corrector failed (the model's domain or a singular extended system)"
            continue
        tests_b = system.tests(b)
        found_here = []
        for k in range(len(tests_a)):
            if tests_a[k] * tests_b[k] < 0:
                f_k = lambda nd, k=k: float(system.tests(nd)[k])  # noqa: E731
                found = locate_zero(system, a, ds, f_k, float(tests_a[k]), float(tests_b[k]), options.max_iterations)
                if found is not None:
                    found_here.append(Crossing(k, found, "converged", s_total + float(a.t @ (found.u - a.u))))
                else:
                    nearer = a if abs(tests_a[k]) <= abs(tests_b[k]) else b
                    found_here.append(Crossing(k, nearer, "guess", s_total + (0.0 if nearer is a else ds)))
        nodes.append(b)
        s_total += ds
        why, drop = stop(nodes, ds)
        if why and drop:
            nodes.pop()
            return nodes, crossings, why  # the crossings of the dropped segment are another curve's
        crossings += found_here
        if why:
            return nodes, crossings, why
        if b.iterations <= 2:
            ds = min(options.ds_max, 1.5 * ds)
        elif b.iterations >= 5:
            ds = max(options.ds_min, 0.5 * ds)
        a, tests_a = b, tests_b
    return nodes, crossings, f"reached {options.max_steps} steps"
