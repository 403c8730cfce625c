"""Benchmark of contact: a contact solve against a free solve, and the blocked-force curve.

In one run, medians over ``repeat`` runs:

* n = 3, P = 0.1 MPa, the flat probe at the tip: the contact solve from rest
  (:func:`esba.statics.contact.solve_contact`: Newton on an active set, IPOPT where that fails),
  the same with IPOPT only, the free solve of its twin scene (a horizontal dead load of the contact
  force, :func:`esba.statics.equilibrium.solve`: the same equilibrium), a naive SciPy script (SLSQP
  on the generated energy and gradient with the gaps at the joints and 8 points per segment), and
  the compiled limit: one Newton solve of the KKT system on the known active set from a
  neighbouring state;
* n = 3 in 3-D: the contact solve of a sphere in the bend (:func:`esba.statics.contact.spatial.solve_contact3d`)
  against the free 3-D solve of the same actuator (:func:`esba.statics.spatial.solve_scene3d`);
* n = 8: the blocked-force curve at 31 pressures 0 to 0.3 MPa (:func:`esba.statics.contact.sweeps.blocked_force`,
  each pressure warm-started from the previous one), and the same with IPOPT at every pressure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from esba.model.contact.obstacles import HalfPlane
from esba.model.contact.surface import surface_points
from esba.model.scene import Payload, Scene
from esba.statics.contact import ContactOptions, solve_contact
from esba.statics.contact.equilibrium import ContactProblem, _newton
from esba.statics.contact.sweeps import blocked_force
from esba.statics.equilibrium import SolverOptions, solve

from .timing import median_time

__all__ = ["ContactBenchRow", "contact_benchmark", "PRESSURES", "SOLVE_RATIO_TARGET", "CURVE_TARGET_S"]

#: The blocked-force curve's pressures.
PRESSURES = tuple(float(p) for p in np.linspace(0.0, 0.3, 31))
#: The targets: a contact solve within this factor of a free solve; the curve within this many seconds.
SOLVE_RATIO_TARGET = 3.0
CURVE_TARGET_S = 1.0


@dataclass(frozen=True)
class ContactBenchRow:
    """One timing: what, n, the median time (s), and how far its answer is from esba's (rad; nan when not comparable)."""

    name: str
    n: int
    seconds: float
    deviation: float
    note: str


def _naive(scene: Scene, samples: int = 8):
    """SLSQP on the generated energy and gradient, the gaps at the joints and ``samples`` points per segment."""
    from scipy.optimize import minimize

    model = scene.model()
    pv = model.param_vector(scene.parameters(scene.pressure))
    probe = scene.obstacles[0]
    grid = np.tile(np.linspace(1.0 / samples, 1.0, samples), (scene.segments, 1))

    def gaps(theta):
        return probe.distance(surface_points(theta, scene.actuator.L, 0.0, grid)).ravel()

    res = minimize(lambda t: model.energy(t, pv), np.zeros(scene.segments), jac=lambda t: model.gradient(t, pv), method="SLSQP",
                   constraints=[{"type": "ineq", "fun": gaps}], options={"ftol": 1e-12, "maxiter": 500})
    return res.x


def contact_benchmark(repeat: int = 5, progress: Callable[[str], None] | None = None) -> dict:
    """The rows (:class:`ContactBenchRow`), the ratio of the contact solve to the free solve and the curve's time."""
    say = progress or (lambda msg: None)
    probe = HalfPlane(at=(135.0, 0.0), normal_deg=90.0)
    scene = Scene(segments=3, pressure=0.1, obstacles=(probe,))
    ref = solve_contact(scene)
    twin = Scene(segments=3, pressure=0.1, payloads=(Payload(ref.contacts[0].force, 90.0, 1.0),))
    step = SolverOptions(multistability="never")
    ipopt_only = ContactOptions(newton=False)
    rows = []

    def row(name, n, fn, theta_of, note):
        out = fn()
        t = median_time(fn, repeat)
        theta = theta_of(out)
        dev = float(np.max(np.abs(theta - ref.theta))) if theta is not None and n == 3 else float("nan")
        rows.append(ContactBenchRow(name, n, t, dev, note))
        say(name)

    row("free solve (dead-load twin)", 3, lambda: solve(twin, step), lambda r: r.theta, "esba.solve, the same equilibrium as a dead load")
    row("contact solve", 3, lambda: solve_contact(scene), lambda r: r.theta, "from rest: active-set Newton, IPOPT where it fails")
    row("contact solve, IPOPT-certified", 3, lambda: solve_contact(scene, ContactOptions(certify=True)), lambda r: r.theta,
        "from rest: active-set Newton, then IPOPT from its result")
    row("contact solve, IPOPT only", 3, lambda: solve_contact(scene, ipopt_only), lambda r: r.theta, "from rest: IPOPT with gap >= 0, closest points updated")
    row("naive SciPy (SLSQP)", 3, lambda: _naive(scene), lambda x: x, "SLSQP, gaps at joints + 8 points per segment")
    prob = ContactProblem(scene, ContactOptions(), None)
    pv = prob.model.param_vector(scene.parameters(0.1))
    near = solve_contact(scene, pressure=0.099)
    lbx = prob.model.lower_bounds(scene.parameters(0.1))
    row("compiled limit: Newton on the active set", 3, lambda: _newton(prob, pv, near.state.theta, near.state.lam_g, near.state.sigma, lbx),
        lambda r: r[0], "one KKT Newton solve from P = 0.099 MPa")
    base = Scene(segments=8)
    curve = blocked_force(base, PRESSURES)
    newton = sum(p.status == "Newton_Active_Set" for p in curve.points)
    row("blocked-force curve, 31 pressures", 8, lambda: blocked_force(base, PRESSURES), lambda r: None,
        f"warm-started; {newton} of 31 by the active set, {31 - newton} by IPOPT")
    row("blocked-force curve, IPOPT at every pressure", 8, lambda: blocked_force(base, PRESSURES, ipopt_only), lambda r: None, "warm-started IPOPT")
    # 3-D (esba.statics.contact.spatial): the sphere in the bend against the free 3-D solve of the same actuator
    from esba.analysis.contact3d_cases import SPHERE_SCENE
    from esba.statics.contact.spatial import ContactProblem3D, solve_contact3d
    from esba.statics.spatial import solve_scene3d

    free3d = SPHERE_SCENE.replace(obstacles=())
    problem3d = ContactProblem3D(SPHERE_SCENE)
    row("3-D free solve", 3, lambda: solve_scene3d(free3d), lambda r: None, "esba.statics.spatial.solve_scene3d, P = 0.14 MPa")
    row("3-D contact solve", 3, lambda: solve_contact3d(SPHERE_SCENE, problem=problem3d), lambda r: None,
        "solve_contact3d from rest, a sphere in the bend (docs/contact.md)")
    free_s = rows[0].seconds
    return {
        "ratio3d": rows[-1].seconds / rows[-2].seconds,
        "rows": rows,
        "ratio": rows[1].seconds / free_s,
        "ratio_target": SOLVE_RATIO_TARGET,
        "curve_s": next(r.seconds for r in rows if r.name == "blocked-force curve, 31 pressures"),
        "curve_target_s": CURVE_TARGET_S,
        "curve_ok": curve.ok,
        "force_at_03": curve.forces[-1],
    }
