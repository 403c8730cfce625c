"""Branch-point curves in two scene parameters: where the in-plane state flips sideways, as a curve.

With loads in the bending plane (every payload at beta = 0, no load across it) the plane psi = tau = 0
is a symmetry of the 3-D model (:mod:`esba.model.spatial`, q = [theta; psi; tau]): at an in-plane
state the gradient's sideways part vanishes and the Hessian splits into the in-plane block H_tt and
the sideways-twist block H_ss (psi, tau). The in-plane state loses stability sideways
(lateral-torsional buckling) where H_ss turns singular: a symmetry-breaking branch point (a
pitchfork) of every one-parameter path through it. With two scene parameters (x, y) these points
form curves, the solutions of

    g_theta(theta; x, y) = 0,   H_ss(theta; x, y) w = 0,   w0 . w = 1

(the in-plane equilibrium with psi = tau = 0, and a sideways null vector w: 3n + 1 equations in the
3n + 2 unknowns theta, x, y, w), which :func:`esba.paths.extended.follow` continues as it does the
fold curves of :mod:`esba.analysis.folds` (the same :class:`~esba.analysis.folds.Plane` of two
:class:`~esba.statics.spatial_paths.SpatialPathProblem`, the same terms by AD with v = (0, w)).
The curves are seeded at the branch points that the path engine finds on one-parameter paths
across the plane (:func:`esba.analysis.folds.seed_points`).

Along a curve three test functions locate its codimension-two points (Brent's method on the
arclength, each a converged point of the system):

* **meets an in-plane fold**: the smallest eigenvalue of H_tt crosses zero (the in-plane state
  folds where it also branches);
* **two branch points of the x-path merge**: mu_x = 0, where mu is the sideways eigenvalue w . H_ss w
  along the in-plane state and mu_x = w . (dH_ss/dx + dH_ss/dtheta . dtheta/dx) w its rate in x
  (dtheta/dx = -H_tt^-1 dg_theta/dx): the curve is tangent to the line y = const (y extremal), the
  path in x at that y touches it; at nearby y the path in x branches twice or not at all;
* likewise **two branch points of the y-path merge**: mu_y = 0 (x extremal on the curve).

The rates are multiplied by det(H_tt) (scaled), which keeps their sign changes away from the
poles where H_tt is singular. A point where every other eigenvalue of the 3-D Hessian is positive
is one where a stable in-plane state loses stability (``stable``).

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> plane = Plane.from_scene3d(Scene(pressure=0.0, payloads=(Payload(1.0, 90.0),)), "pressure", "payload")
>>> box = ((0.05, 0.3), (0.2, 3.0))
>>> curves = branch_point_curves(plane, *box)
>>> [round(p, 6) for p in branch_points_at(plane, curves, box, y=1.0)]  # the pressure path's, under 1 N (MPa)
[0.108829, 0.253417]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from esba.paths.extended import Node
from esba.paths.problem import PathError

from .folds import Curve, CurveSystem, FoldOptions, Plane, _box, crossings, seed_points, trace_curves

__all__ = ["KINDS_BP", "BranchCurve", "branch_point_curves", "branch_points_at", "seed_branch_points", "check_symmetric"]

#: The codimension-two points located on a branch-point curve.
KINDS_BP = ("meets an in-plane fold", "two branch points of the x-path merge", "two branch points of the y-path merge")

#: Largest sideways gradient and in-plane/sideways Hessian coupling, relative to the gradient's and
#: the Hessian's size, at an in-plane state of a plane whose loads lie in the bending plane (round-off).
SYMMETRY_TOL = 1e-12


@dataclass(frozen=True, eq=False)
class BranchCurve(Curve):
    """A traced branch-point curve (see :class:`esba.analysis.folds.Curve`): ``theta`` the in-plane
    states (3-D, psi = tau = 0), ``v`` the sideways null vectors (0, w); its tests are the smallest
    eigenvalue of H_tt (scaled) and det(H_tt) mu_x, det(H_tt) mu_y (see the module); ``stable`` per
    point: the in-plane state is stable on one side (it loses stability sideways there)."""

    TESTS = ("inplane_min_eig", "mu_x", "mu_y")
    STABLE = "loses_stability"

    @property
    def merges(self):
        """The points where two branch points of a one-parameter path merge."""
        return tuple(p for p in self.special if p.kind in KINDS_BP[1:])


class _BranchSystem(CurveSystem):
    """The branch-point system of one plane in u = (theta, x / sx, y / sy, w): g_theta = 0,
    H_ss w = 0, w0 . w = 1 (w0 the anchor's w); 3n + 1 equations in 3n + 2 unknowns (n segments)."""

    curve = BranchCurve
    what = "branch-point curve"

    def __init__(self, plane: Plane, spans: tuple[float, float], opts: FoldOptions):
        n = plane.segments
        super().__init__(plane, spans, opts, np.arange(n), np.arange(n, 3 * n))
        self.n = n

    def tests(self, node: Node) -> np.ndarray:
        """(smallest eigenvalue of H_tt / its size, det(H_tt / size) mu_x, det(H_tt / size) mu_y) (w unit)."""
        _, h, gx, gy, _, hvt, hvx, hvy = node.data
        n = self.n
        w = node.u[self.m + 2 :]
        size_w = float(np.linalg.norm(w))
        w = w / size_w
        htt = h[:n, :n]
        size = float(np.max(np.abs(htt)))
        eig = np.linalg.eigvalsh(htt / size)
        det = float(np.prod(eig))
        rates = []
        for g_l, hv_l in ((gx, hvx), (gy, hvy)):
            dtheta = -np.linalg.solve(htt, g_l[:n])
            # hv_l, hvt are linear in the node's v = (0, |w| w): w . (dH_ss/dl w + d(H_ss w)/dtheta . dtheta/dl)
            rates.append(det * float(w @ (hv_l[n:] + hvt[n:, :n] @ dtheta)) / size_w)
        return np.array([float(eig[0]), *rates])


def check_symmetric(plane: Plane, box) -> None:
    """Refuse a plane whose loads leave the bending plane: at an in-plane state at the box's corners
    the sideways gradient and the coupling of the in-plane and sideways Hessian blocks must vanish."""
    if not plane.spatial:
        raise PathError("branch-point curves: the plane is the planar model's; build it with Plane.from_scene3d (the 3-D model)")
    n = plane.segments
    q = np.concatenate([np.full(n, 0.5 / n), np.zeros(2 * n)])
    for x in box[0]:
        for y in box[1]:
            g, h, gx = plane.along_x(y).ghl(q, x)
            gs = max(float(np.max(np.abs(g))), float(np.max(np.abs(gx))), 1e-300)
            hs = max(float(np.max(np.abs(h))), 1e-300)
            if max(np.max(np.abs(g[n:])), np.max(np.abs(gx[n:]))) > SYMMETRY_TOL * gs or np.max(np.abs(h[:n, n:])) > SYMMETRY_TOL * hs:
                raise PathError(
                    f"branch-point curves: at {plane.names[0]}={x:g}, {plane.names[1]}={y:g} the loads leave the bending plane "
                    "(the in-plane state is no equilibrium of the 3-D model): they need every payload in the plane (beta = 0); "
                    "off the plane the branch points unfold into folds (esba.analysis.folds.fold_curves)"
                )


def seed_branch_points(plane: Plane, box, lines: int = 5) -> list[tuple[np.ndarray, float, float, np.ndarray]]:
    """The sideways branch points (q, x, y, v) that the path engine finds on ``lines`` paths in x and
    in y across the box (:func:`esba.analysis.folds.seed_points`): those whose mode is sideways (psi, tau)."""
    n = plane.segments
    out = []
    for q, x, y, v in seed_points(plane, box, lines, "branch point"):
        v = np.asarray(v, dtype=float)
        if float(v[n:] @ v[n:]) > 0.5 * float(v @ v) and float(np.max(np.abs(np.asarray(q)[n:]))) <= 1e-8:
            out.append((q, x, y, v))
    return out


def branch_point_curves(plane: Plane, xrange, yrange, options: FoldOptions | None = None, lines: int = 5, seeds=None) -> list[BranchCurve]:
    """Every branch-point curve of the in-plane state in the box that ``lines`` x-paths and y-paths
    cross (or through ``seeds``, (q, x, y, v) of the 3-D model), for a 3-D plane whose loads lie in
    the bending plane (:func:`check_symmetric`)."""
    check_symmetric(plane, _box(plane, xrange, yrange))
    return trace_curves(plane, xrange, yrange, _BranchSystem, seed_branch_points, KINDS_BP, options, lines, seeds)  # type: ignore[return-value]


def branch_points_at(plane: Plane, curves: Sequence[BranchCurve], box, *, x: float | None = None, y: float | None = None,
                     options: FoldOptions | None = None) -> list[float]:
    """Where the branch-point curves cross the line y = const (the branch points of the x-path there;
    or x = const), each corrected on the system at that y (or x), sorted."""
    spans = (box[0][1] - box[0][0], box[1][1] - box[1][0])
    return [f for f, _ in crossings(_BranchSystem(plane, spans, options or FoldOptions()), curves, x=x, y=y)]
