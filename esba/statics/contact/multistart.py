"""Equilibria of a scene with obstacles, from every equilibrium of the free actuator.

:func:`contact_equilibria` finds every equilibrium of the actuator without its obstacles
(:func:`esba.statics.equilibria.equilibria`, deflated Newton), and from each solves the contact
problem at the same pressure (:func:`esba.statics.contact.solve_contact` warm-started there: a
free state clear of the obstacles is its own answer; one that reaches into an obstacle is pushed
out by the active set, or IPOPT; one that lies through it, rather than against it, is dropped).
The state the load history reaches (:func:`solve_contact` from rest) is always tried. The distinct
results are the contact equilibria found, each with its contacts, KKT numbers and
stability on the constrained set. It is a multistart, not a proof that there are no others.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from esba.model.scene import Scene

from .equilibrium import ContactEquilibrium, ContactOptions, ContactProblem, ContactState, _closest, solve_contact

__all__ = ["ContactEquilibria", "contact_equilibria", "ContactEquilibria3D", "contact_equilibria3d"]


@dataclass(frozen=True, eq=False)
class ContactEquilibria:
    """The contact equilibria found (least energy first), the pressure, and how many free equilibria they came from."""

    pressure: float
    states: tuple[ContactEquilibrium, ...]
    free_states: int
    dropped: int

    def to_dict(self) -> dict[str, Any]:
        return {
            "pressure_mpa": self.pressure,
            "free_equilibria": self.free_states,
            "dropped": self.dropped,
            "method": "from every equilibrium of the free actuator (deflated Newton), the contact solve at the same pressure",
            "states": [s.to_dict(centreline=True) for s in self.states],
        }


def contact_equilibria(scene: Scene, options: ContactOptions | None = None) -> ContactEquilibria:
    """The equilibria of ``scene`` (with obstacles) reached from each free equilibrium (see the module)."""
    from esba.statics.equilibria import EquilibriaOptions, equilibria

    options = ContactOptions() if options is None else options
    free = equilibria(scene.replace(obstacles=()), EquilibriaOptions(check=False))
    prob = ContactProblem(scene, options, None)
    p = free.pressure
    history = solve_contact(scene, options, pressure=p, problem=prob)  # the state the load history reaches, first
    found: list[ContactEquilibrium] = [history] if history.success else []
    dropped = 0
    for st in free.states:
        sigma, _ = _closest(scene, st.theta, prob.offsets)
        r = solve_contact(scene, options, pressure=p, warm=ContactState(np.asarray(st.theta), np.zeros(prob.m + 2), sigma, p, 1.0), problem=prob)
        if not r.success:
            dropped += 1
            continue
        if not any(np.max(np.abs(r.theta - f.theta)) < 1e-6 for f in found):
            found.append(r)
    found.sort(key=lambda r: r.energy)
    return ContactEquilibria(p, tuple(found), len(free.states), dropped)


@dataclass(frozen=True, eq=False)
class ContactEquilibria3D:
    """The 3-D contact equilibria found (least energy first), the pressure, and how many free 3-D
    equilibria they came from (``dropped``: those from which no contact equilibrium was reached)."""

    pressure: float
    states: tuple
    free_states: int
    dropped: int
    section: dict

    def to_dict(self) -> dict[str, Any]:
        return {
            "pressure_mpa": self.pressure,
            "free_equilibria": self.free_states,
            "dropped": self.dropped,
            "three_d": True,
            "section_nmm2": dict(self.section),
            "method": "from every 3-D equilibrium of the free actuator (esba.statics.spatial_search), the 3-D contact solve at the same load",
            "states": [s.to_dict() for s in self.states],
        }


def contact_equilibria3d(scene: Scene, section=None, options: ContactOptions | None = None, *, gravity_direction=None,
                         starts: int | None = None) -> ContactEquilibria3D:
    """The 3-D equilibria of ``scene`` (with obstacles) reached from each free 3-D equilibrium.

    As :func:`contact_equilibria`, in space: every equilibrium of the actuator without its obstacles
    (:func:`esba.statics.spatial_search.search3d`), and from each the contact problem at the full load
    (:mod:`esba.statics.contact.spatial`: a free state clear of the obstacles is its own answer; one
    that reaches into an obstacle is pushed out by IPOPT with the gap constraints, then Newton on the
    active set, and kept when every KKT condition holds: a state that lay through a sphere may come
    out on its far side, a constrained equilibrium all the same, which the load history may never
    reach). Each is listed with its stability on the constrained set. The state the load history reaches (:func:`esba.statics.contact.spatial.solve_contact3d` from rest) is
    always tried first. A multistart, not a proof that there are no others.
    """
    from esba.statics.spatial_search import search3d

    from .spatial import GRID, ContactProblem3D, _lb, _result, _stage, solve_contact3d

    prob = ContactProblem3D(scene, section, gravity_direction) if options is None else ContactProblem3D(scene, section, gravity_direction, options)
    free = search3d(scene.replace(obstacles=()), section, gravity_direction=gravity_direction, starts=starts, check=False)
    history = solve_contact3d(scene, section, options, gravity_direction=gravity_direction, problem=prob)
    found = [history] if history.success else []
    values = dict(prob.values)
    pv, lb = prob.model.param_vector(values), _lb(prob, values)
    tol = prob.options.gap_tol
    grid = np.linspace(0.0, 1.0, GRID)
    dropped = 0
    for st in free.states:
        q0 = np.asarray(st.q, dtype=float)
        sigma, interior, _ = prob.closest(q0, pv)
        least = float(np.min(np.asarray(prob.nlp.grid(q0, pv, prob.po, np.broadcast_to(grid, (prob.K * prob.n, grid.size))))))
        if least >= -tol:  # clear of every obstacle: a free equilibrium is a contact one
            q, force, status, success = q0, np.zeros(prob.m), "free equilibrium, clear of every obstacle", True
        else:  # it reaches into an obstacle: pushed out at the same load
            q, force, sigma, interior, status, success, _, _ = _stage(prob, pv, q0, None, lb)
        r = _result(prob, pv, float(values.get("P", 0.0)), q, force, sigma, interior, status, success, 0, 0, 0, 0.0, lb) if success else None
        if r is None or not r.success:
            dropped += 1
            continue
        if not any(np.max(np.abs(r.q - f.q)) < 1e-6 for f in found):
            found.append(r)
    found.sort(key=lambda r: r.energy)
    return ContactEquilibria3D(float(values.get("P", 0.0)), tuple(found), len(free.states), dropped,
                               {k: float(values[k]) for k in ("EI_side", "GJ") if k in values})
