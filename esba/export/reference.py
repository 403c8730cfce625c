"""What Python gives for an export's call: the reference of the README's example line.

:func:`reference_equilibrium` is :func:`esba.statics.equilibrium.solve`'s load history on a
model's parameter vectors, for any effect set (a :class:`~esba.model.scene.Scene` cannot say
"no radial term"): the pressure raised from theta = 0 with the loads off, then the payloads and
weight together, each ramp followed by :func:`esba.paths.loading.follow` (folds located, snaps
followed), and IPOPT with the Newton polish at the end (:func:`esba.solvers.minimise.minimise`).
A test checks that it is ``solve()``'s answer where a scene can say it.

Examples
--------
>>> import math
>>> from esba.model.generated import load_model
>>> values = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54,
...           "P": 0.12, "F1": 2.0, "Omega1": math.pi / 2, "s1": 1.0}
>>> r = reference_equilibrium(load_model(3), values)
>>> r["ok"], r["snapped"], [round(math.degrees(t), 2) for t in r["theta"]]
(True, False, [-3.95, 6.25, 20.24])
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from esba.model.closed_form import load_parameter
from esba.model.generated import Model, near_domain_bound
from esba.model.stability import stability_verdict
from esba.paths.loading import follow
from esba.paths.problem import PathProblem
from esba.solvers.minimise import minimise

__all__ = ["reference_equilibrium"]


def reference_equilibrium(model: Model, values: Mapping[str, float]) -> dict:
    """The equilibrium reached along solve()'s load history at ``values`` (every parameter of the
    model, radians): theta (rad), total angle (rad), tip (x, y mm), ``snapped``, ``ok``, ``stability``."""
    full = model.param_vector(values)
    unloaded = model.param_vector({k: (0.0 if load_parameter(k) else v) for k, v in values.items()})
    straight = model.param_vector({k: (0.0 if load_parameter(k) or k == "P" else v) for k, v in values.items()})
    n = model.n
    theta = np.zeros(n)
    snapped, reached = False, True
    for p_from, p_to in ((straight, unloaded), (unloaded, full)):
        if np.all(p_from == p_to):
            continue
        ramp = follow(PathProblem.homotopy(model, p_from, p_to), theta, 0.0, 1.0)
        theta = ramp.theta
        snapped = snapped or bool(ramp.jumps)
        if not ramp.reached:
            reached = False
            break
    lbx = model.lower_bounds(values)
    final = minimise(model, theta, full, lbx, warm=True)
    state = model.state(final.theta, full)
    eig = np.linalg.eigvalsh(state["hessian"])
    stability = stability_verdict(eig)
    ok = bool(reached and final.success and stability == "stable" and not near_domain_bound(final.theta, lbx)
              and float(np.max(np.abs(state["gradient"]))) <= 1e-7)
    return {
        "theta": final.theta,
        "total_angle": float(np.sum(final.theta)),
        "tip": state["tip"][:2],
        "snapped": snapped,
        "ok": ok,
        "stability": stability,
        "total_angle_deg": math.degrees(float(np.sum(final.theta))),
    }
