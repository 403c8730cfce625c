"""A 3-D path in pressure through contact events: each point warm-started from the previous one
(:func:`esba.statics.contact.spatial.solve_contact3d` with ``warm``), and each change of the set of
contacts (a touch, a lift-off) located by bisection on the pressure to ``tol`` MPa.

A contact is identified by its obstacle and its constraint (a segment's end, its moving closest
point, or a fixed point of it); a contact that moves between a segment's points without losing its
force is not an event here (the planar path, :func:`esba.statics.contact.sweeps.contact_path`, also
locates slides; this one does not yet).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from esba.model.scene import Scene

from .equilibrium import ContactOptions
from .spatial import ContactEquilibrium3D, ContactProblem3D, solve_contact3d

__all__ = ["ContactEvent3D", "ContactPath3D", "contact_path3d"]


@dataclass(frozen=True)
class ContactEvent3D:
    """``touch`` or ``lift-off`` of obstacle ``obstacle`` at ``pressure`` (MPa, within ``bracket``), at ``s`` (fraction of L)."""

    kind: str
    obstacle: int
    pressure: float
    bracket: tuple[float, float]
    s: float

    def describe(self) -> str:
        return f"{self.kind} of obstacle #{self.obstacle + 1} at s = {self.s:.3f}: P = {self.pressure:.6f} MPa (bracket {self.bracket[1] - self.bracket[0]:.1e} MPa)"


@dataclass(frozen=True, eq=False)
class ContactPath3D:
    pressures: tuple[float, ...]
    points: tuple[ContactEquilibrium3D, ...]
    events: tuple[ContactEvent3D, ...] = field(default=())

    @property
    def ok(self) -> bool:
        return all(p.ok for p in self.points)

    def forces(self) -> np.ndarray:
        """The total contact force's size at each pressure, N."""
        return np.array([float(np.linalg.norm(p.total_force)) for p in self.points])


def _touching(r: ContactEquilibrium3D) -> dict[int, set]:
    """Per obstacle, whether it touches (an event is a change of that)."""
    return {k: any(c.obstacle == k for c in r.contacts) for k in range(len(r.obstacles))}


def contact_path3d(scene: Scene, pressures: Sequence[float], section: Mapping[str, float] | None = None, options: ContactOptions | None = None, *,
                   tol: float = 1e-6) -> ContactPath3D:
    """The 3-D equilibria of ``scene`` (with obstacles) at ``pressures`` (increasing or decreasing), the
    first from rest and each next one from the previous; touches and lift-offs located to ``tol`` MPa."""
    pressures = tuple(float(p) for p in pressures)
    problem = ContactProblem3D(scene, section, options=options) if options is not None else ContactProblem3D(scene, section)
    points: list[ContactEquilibrium3D] = []
    events: list[ContactEvent3D] = []
    prev = None
    for p in pressures:
        r = solve_contact3d(scene, problem=problem, pressure=p, warm=prev) if prev is not None else solve_contact3d(scene, problem=problem, pressure=p)
        if prev is not None and r.success and prev.success:
            before, after = _touching(prev), _touching(r)
            for k in before:
                if before[k] != after[k]:
                    lo, hi, lo_state = prev.pressure, r.pressure, prev
                    while abs(hi - lo) > tol:
                        mid = 0.5 * (lo + hi)
                        m = solve_contact3d(scene, problem=problem, pressure=mid, warm=lo_state)
                        if not m.success:
                            break
                        if _touching(m)[k] == before[k]:
                            lo, lo_state = mid, m
                        else:
                            hi = mid
                    where = next((c.s for c in (r if after[k] else lo_state).contacts if c.obstacle == k), float("nan"))
                    events.append(ContactEvent3D("touch" if after[k] else "lift-off", k, 0.5 * (lo + hi), (min(lo, hi), max(lo, hi)), where))
        points.append(r)
        prev = r if r.success else None
    return ContactPath3D(pressures, tuple(points), tuple(events))
