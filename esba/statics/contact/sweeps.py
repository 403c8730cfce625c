"""Paths with contact: the blocked-force curve, a finger closing on a cylinder, a tester's displacement path.

:func:`contact_path` follows a scene with obstacles along one parameter (the pressure, or a
prescribed tip coordinate), each point warm-started from the previous one (Newton on the previous
active set, checked; IPOPT where that fails), and locates every contact event between two points
(:mod:`esba.paths.events`: touch, lift-off, slide) on the continuation of the old active set.

* :func:`blocked_force`: a frictionless flat probe touching the tip of the unpressurised actuator
  from the bending side (the face y = 0 through the tip, looking towards -y) while the pressure
  rises; the actuator bends into an S against it. The blocked force is the contact force.
* :func:`grasp`: a cylinder of radius R at a given centre; the contact force and contact length
  against pressure and the pressure at which it first touches.
* :func:`displacement_path`: the tip's horizontal coordinate prescribed at a fixed pressure, the reaction
  force read, through the negative stiffness that a force-controlled ramp (:func:`force_ramp`) snaps across.

Examples
--------
>>> from esba.model.scene import Scene
>>> b = blocked_force(Scene(segments=3), [0.0, 0.05, 0.1])
>>> [round(f, 3) for f in b.forces]
[0.0, 0.893, 1.83]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.errors import InputError
from esba.model.contact.obstacles import Cylinder, HalfPlane
from esba.model.contact.surface import surface_derivatives
from esba.model.scene import Payload, Scene, check_pressure
from esba.paths.events import ContactEvent, bisect_event, locate_event

from .equilibrium import ContactEquilibrium, ContactOptions, ContactProblem, Displacement, _active_set, _closest, _crosses, _newton, _pack, solve_contact

__all__ = ["ContactPath", "contact_path", "blocked_force", "grasp", "displacement_path", "force_ramp", "ForceRamp", "MAX_POINTS"]

#: The most points a contact path takes (each a solve).
MAX_POINTS = 10_000


@dataclass(frozen=True, eq=False)
class ContactPath:
    """The equilibria of a path with contact and its located events.

    ``parameter`` names what changes (``pressure`` in MPa, ``tip_y`` in mm); ``values`` its values;
    ``points`` the equilibria; ``events`` the contact events between them.
    """

    parameter: str
    values: np.ndarray
    points: tuple[ContactEquilibrium, ...]
    events: tuple[ContactEvent, ...]

    @property
    def forces(self) -> list[float]:
        """The size of the total contact force at each point, N."""
        return [float(np.linalg.norm(p.total_force)) for p in self.points]

    @property
    def ok(self) -> bool:
        return all(p.ok for p in self.points)

    @property
    def reactions(self) -> np.ndarray:
        """The reaction of each point's prescribed tip, N, shape (m, 2): NaN where there is none (no
        prescribed tip, or a failed solve)."""
        return np.array([[math.nan, math.nan] if p.reaction is None else p.reaction for p in self.points], dtype=float).reshape(-1, 2)

    @property
    def first_touch(self) -> float | None:
        """The parameter of the first touch event (None when nothing touches on the way)."""
        touches = [e.parameter for e in self.events if e.kind == "touch"]
        return min(touches) if touches else None

    def to_dict(self, shapes: bool = True) -> dict[str, Any]:
        return {
            "parameter": self.parameter,
            "values": self.values.tolist(),
            "ok": self.ok,
            "forces_n": self.forces,
            "first_touch": self.first_touch,
            "events": [e.to_dict() for e in self.events],
            "points": [p.to_dict(centreline=shapes) for p in self.points],
        }


def _check_values(name: str, values: Sequence[float], check: Callable[[Any, str], float]) -> np.ndarray:
    try:
        items = list(values)
    except TypeError:
        raise InputError(f"{name}={checks.quote(values)}: expected a list of numbers") from None
    if not 1 <= len(items) <= MAX_POINTS:
        raise InputError(f"{name}: {len(items)} values; expected 1 to {MAX_POINTS}")
    return np.array([check(v, f"{name}[{k}]") for k, v in enumerate(items)])


def _label(prob: ContactProblem, j: int) -> tuple[str, str, int, int]:
    """(where on the body, which obstacle, obstacle index, segment) of constraint ``j``."""
    n = prob.n
    k, local = divmod(j, 2 * n)
    o = prob.scene.obstacles[k]
    name = f"{o.kind} #{k + 1}"
    if local < n:
        return ("tip" if local == n - 1 else f"joint {local + 1}"), name, k, local
    return f"inside segment {local - n + 1}", name, k, local - n


def _events(prob: ContactProblem, setup: Callable[[float], tuple[np.ndarray, np.ndarray]], a: ContactEquilibrium, b: ContactEquilibrium,
            va: float, vb: float) -> list[ContactEvent]:
    """The events between two points of a path: each change of the active set, located on the old set's
    continuation; a contact that ends with force left where the solves from ``a`` lose it (:func:`_lift_off_or_lost`)."""
    m, tol = prob.m, prob.options.force_tol
    old = -a.state.lam_g[:m] > tol
    new = (-b.state.lam_g[:m] > tol) if b.success else np.zeros(m, dtype=bool)  # a failed solve's multipliers are no contacts
    if np.array_equal(old, new):
        return []
    mask = np.concatenate([old, prob.fixed])

    def continued(v: float):
        pv, lbx = setup(v)
        theta, lam, sigma, fine = _newton(prob, pv, a.state.theta, a.state.lam_g, a.state.sigma, lbx, steps=30, active=mask, checked=False)
        if not fine:
            return None
        sigma, _ = _closest(prob.scene, theta, prob.offsets)
        g = np.asarray(prob.nlp.terms(theta, _pack(pv, prob.scene, prob.offsets, sigma), lam)[0], dtype=float).ravel()
        return g, -lam

    n, m2 = prob.n, 2 * prob.n
    gained, lost = set(np.flatnonzero(new & ~old).tolist()), set(np.flatnonzero(old & ~new).tolist())

    def joint(k: int, i: int) -> int:  # the constraint of joint i + 1 (the end of segment i)
        return k * m2 + i

    def inside(k: int, i: int) -> int:  # the constraint inside segment i
        return k * m2 + n + i

    def slope(k: int, i: int, end: float, sign: float, held: int = -1, by: int = -1):
        """d(gap)/d(sigma) at one end of segment i, on the continuation of the old active set (with the
        contact ``held`` held at the joint ``by`` instead: both continuations meet at the event)."""
        use, lam0 = mask.copy(), a.state.lam_g.copy()
        if held >= 0:
            use[held], use[by] = False, True
            lam0[by], lam0[held] = lam0[held], 0.0

        def f(v: float) -> float:
            pv, lbx = setup(v)
            theta, _, _, fine = _newton(prob, pv, a.state.theta, lam0, a.state.sigma, lbx, steps=30, active=use, checked=False)
            if not fine:
                return math.nan
            q, q1, _ = surface_derivatives(theta, prob.scene.actuator.L, prob.offsets[k], np.full((n, 1), end))
            _, g, _ = prob.scene.obstacles[k].derivatives(q[i:i + 1, 0])
            return sign * float(g[0] @ q1[i, 0])
        return f

    out = []
    for j in sorted(lost):  # a contact that slides across an end of its segment: one event, located where the gap's slope there changes sign
        k, local = divmod(j, m2)
        name = f"{prob.scene.obstacles[k].kind} #{k + 1}"
        if local >= n:
            i = local - n
            for to, end, sign in ((joint(k, i), 1.0, 1.0), (inside(k, i + 1) if i + 1 < n else -1, 1.0, 1.0),
                                  (joint(k, i - 1) if i > 0 else -1, 0.0, -1.0), (inside(k, i - 1) if i > 0 else -1, 0.0, -1.0)):
                if to in gained:
                    at = "the tip" if end == 1.0 and i == n - 1 else f"joint {i + (1 if end == 1.0 else 0)}"
                    # the layer is tangent-continuous at a joint: a contact reaches the joint and leaves it
                    # into the next segment at one instant, so across a joint is one event
                    where = f"from inside segment {i + 1} " + (f"across {at} into segment {to % m2 - n + 1}" if to % m2 >= n else f"onto {at}")
                    by = joint(k, i) if end == 1.0 else joint(k, i - 1)
                    out.append(locate_event(slope(k, i, end, sign, held=j, by=by), va, vb, "slide", where, name))
                    lost.discard(j)
                    gained.discard(to)
                    break
        else:
            i = local
            for to, seg, end, sign in ((inside(k, i + 1) if i + 1 < n else -1, i + 1, 0.0, 1.0), (inside(k, i), i, 1.0, -1.0)):
                if to in gained:
                    out.append(locate_event(slope(k, seg, end, sign), va, vb, "slide", f"from joint {i + 1} into segment {seg + 1}", name))
                    lost.discard(j)
                    gained.discard(to)
                    break
    for j in sorted(gained):
        where, name, _, _ = _label(prob, j)

        def gap(v: float, j: int = j) -> float:
            r = continued(v)
            return math.nan if r is None else float(r[0][j])

        out.append(locate_event(gap, va, vb, "touch", where, name))
    for j in sorted(lost):
        where, name, _, _ = _label(prob, j)

        def force(v: float, j: int = j) -> float:
            r = continued(v)
            return math.nan if r is None else float(r[1][j])

        out.append(_lift_off_or_lost(prob, setup, j, locate_event(force, va, vb, "lift-off", where, name), a, b, va))
    return sorted(out, key=lambda e: e.parameter)


#: A contact whose force, at the last equilibrium that holds it before it is lost, is above this
#: fraction of its force at the path's previous point ended with force left (``contact lost``): at a
#: lift-off located to 1e-10 the force left is of that order of the previous one.
LOST_FORCE_FRACTION = 1e-3


def _lift_off_or_lost(prob: ContactProblem, setup: Callable[[float], tuple[np.ndarray, np.ndarray]], j: int, lift: ContactEvent,
                      a: ContactEquilibrium, b: ContactEquilibrium, va: float) -> ContactEvent:
    """Constraint ``j``, active at ``a`` and not at ``b``: a ``lift-off`` (its force goes to zero) or a
    ``contact lost`` (the contact branch ends with force left, and the actuator snaps).

    The lift-off located on the old active set's continuation is kept when ``b`` is an equilibrium and
    the active-set Newton solve from ``a`` (first-order KKT conditions checked, no step through an
    obstacle) just before it holds the contact with almost no force left. Else the end of the contact
    is located by bisection on the load, each solve from the last equilibrium that held it, and its
    force there says which of the two events it is."""
    tol = prob.options.force_tol
    force_a = float(-a.state.lam_g[j])
    clear = max(LOST_FORCE_FRACTION * force_a, 10.0 * tol)
    last = {"state": (a.state.theta, a.state.lam_g, a.state.sigma), "force": force_a}

    def holds(v: float) -> bool:
        theta, lam, sigma = last["state"]
        pv, lbx = setup(v)
        found = _active_set(prob, pv, theta, lam, sigma, lbx)
        if found is None or _crosses(prob, theta, found[0]) or -found[1][j] <= tol:
            return False
        last["state"], last["force"] = found, float(-found[1][j])
        return True

    if b.success and lift.status == "converged":
        if holds(lift.parameter - 1e-6 * (lift.parameter - va)) and last["force"] <= clear:
            return lift
        last = {"state": (a.state.theta, a.state.lam_g, a.state.sigma), "force": force_a}
    ended = bisect_event(holds, va, lift.bracket[1], "contact lost", lift.where, lift.obstacle)
    if last["force"] <= clear:  # the force went to zero: a lift-off the continuation did not locate
        return replace(ended, kind="lift-off")
    return replace(ended, force_left=last["force"])


def contact_path(scene: Scene, values: Sequence[float], parameter: str = "pressure", options: ContactOptions | None = None,
                 pressure: float | None = None) -> ContactPath:
    """Follow ``scene`` (with obstacles) along ``values`` of ``parameter``: ``pressure`` (MPa) or
    ``tip_y`` / ``tip_x`` (the prescribed tip coordinate, mm, at ``pressure``)."""
    if parameter not in ("pressure", "tip_x", "tip_y"):
        raise InputError(f"parameter={checks.quote(parameter)}: allowed are pressure, tip_x, tip_y")
    options = ContactOptions() if options is None else options
    if parameter == "pressure":
        values = _check_values("pressure", values, check_pressure)
    else:
        values = _check_values(parameter, values, lambda v, w: checks.finite(w, v, InputError))
        pressure = check_pressure(scene.pressure if pressure is None else pressure)

    def displacement(v: float) -> Displacement | None:
        if parameter == "pressure":
            return None
        return Displacement(x=v) if parameter == "tip_x" else Displacement(y=v)

    if parameter != "pressure":
        for v in values:  # every target within reach, before any solve
            displacement(v).check_reach(scene.actuator.L)
    prob = ContactProblem(scene, options, displacement(values[0]))
    model = prob.model

    def setup(v: float) -> tuple[np.ndarray, np.ndarray]:
        p = v if parameter == "pressure" else pressure
        prob.set_displacement(displacement(v))
        full = scene.parameters(p)
        return model.param_vector(full), model.lower_bounds(full)

    points: list[ContactEquilibrium] = []
    events: list[ContactEvent] = []
    state = None
    for k, v in enumerate(values):
        p = float(v) if parameter == "pressure" else pressure
        r = solve_contact(scene, options, pressure=p, displacement=displacement(v), warm=state, problem=prob)
        if points and points[-1].success:
            events += _events(prob, setup, points[-1], r, float(values[k - 1]), float(v))
            prob.set_displacement(displacement(v))
        points.append(r)
        state = r.state
    return ContactPath(parameter, values, tuple(points), tuple(events))


def blocked_force(scene: Scene, pressures: Sequence[float], options: ContactOptions | None = None) -> ContactPath:
    """The blocked-force curve: a frictionless flat probe at the tip of the unpressurised actuator, bending side.

    The probe is the half-plane y >= 0 through the tip at rest, its face looking towards -y: it
    touches the whole layer at P = 0 and holds the tip where it was while the rest of the actuator
    bends away from it into an S. ``scene``'s payloads, gravity and obstacles are replaced.
    """
    probe = HalfPlane(at=(scene.actuator.L, 0.0), normal_deg=90.0)
    base = scene.replace(payloads=(), gravity=False, obstacles=(probe,), pressure=0.0)
    return contact_path(base, pressures, "pressure", options)


def grasp(scene: Scene, centre: tuple[float, float], radius: float, pressures: Sequence[float], options: ContactOptions | None = None) -> ContactPath:
    """A finger closing on a cylinder of ``radius`` at ``centre`` (mm) as the pressure rises."""
    cyl = Cylinder(centre=centre, radius=radius)
    base = scene.replace(obstacles=(cyl,), pressure=0.0)
    return contact_path(base, pressures, "pressure", options)


@dataclass(frozen=True, eq=False)
class ForceRamp:
    """A quasi-static force-controlled ramp: the force, the tip's y at each step, and where it jumped."""

    forces: np.ndarray
    tip_y: np.ndarray
    jumps: tuple[tuple[float, float, float], ...]  # (force, tip y before, tip y after)

    def to_dict(self) -> dict[str, Any]:
        return {"forces_n": self.forces.tolist(), "tip_y_mm": self.tip_y.tolist(),
                "jumps": [{"force_n": f, "tip_y_before_mm": a, "tip_y_after_mm": b} for f, a, b in self.jumps]}


def force_ramp(scene: Scene, pressure: float, forces: Sequence[float], jump_mm: float = 5.0, theta0: Sequence[float] | None = None) -> ForceRamp:
    """A horizontal tip force (a dead load at 90 degrees) raised through ``forces`` at ``pressure``, each
    step an IPOPT solve from the previous state (the quasi-static ramp a force-controlled tester makes):
    where the stable branch ends it falls to another, a jump of the tip larger than ``jump_mm``."""
    from esba.statics.equilibrium import SolverOptions, solve

    forces = _check_values("forces", forces, lambda v, w: checks.finite(w, v, InputError))
    theta = None if theta0 is None else np.asarray(theta0, dtype=float)
    ys, jumps = [], []
    opts = SolverOptions(multistability="never")
    base = scene.replace(obstacles=(), pressure=pressure)
    for f in forces:
        s = base.replace(payloads=(Payload(abs(float(f)), 90.0 if f >= 0 else 270.0, 1.0),))
        r = solve(s, opts) if theta is None else solve(s, opts, theta0=theta)
        if ys and abs(r.tip[1] - ys[-1]) > jump_mm:
            jumps.append((float(f), float(ys[-1]), float(r.tip[1])))
        ys.append(float(r.tip[1]))
        theta = r.theta
    return ForceRamp(forces, np.array(ys), tuple(jumps))


def displacement_path(scene: Scene, pressure: float, tip_y: Sequence[float], options: ContactOptions | None = None) -> ContactPath:
    """The tip's horizontal coordinate prescribed through ``tip_y`` (mm) at ``pressure``, x free (a
    frictionless tester); each point's ``reaction`` is the force the tester applies. ``scene``'s
    payloads are removed (the tester replaces them); its obstacles stay."""
    base = scene.replace(payloads=(), pressure=pressure)
    return contact_path(base, tip_y, "tip_y", options, pressure=pressure)
