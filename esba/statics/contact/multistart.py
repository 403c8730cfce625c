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

__all__ = ["ContactEquilibria", "contact_equilibria"]


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
