"""A 3-D path in pressure through contact events: each point warm-started from the previous one
(:func:`esba.statics.contact.spatial.solve_contact3d` with ``warm``), and each change of where an
obstacle touches located by bisection on the pressure to ``tol`` MPa:

* ``touch`` and ``lift-off``: the obstacle starts or stops touching;
* ``slide``: it touches before and after, but elsewhere: the contact slides from inside a segment onto
  the tip or a joint, across a joint into the next segment, or back (where an obstacle touches is the set
  of its contacts' places: ``tip``, ``joint k``, ``inside segment i``; moving along a segment is no event);
* ``lost``: the solve from the previous point finds no equilibrium in contact beyond some pressure
  (``Contact_Equilibrium_Lost``: the contact branch ends at a fold, where the contact slides off, over the
  rounded tip or off a sphere, and the actuator jumps); located where that solve stopped, to a step of
  2^-10 of the path's step. The points after it are solved from rest.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from esba.model.scene import Scene

from .equilibrium import ContactOptions
from .spatial import LOST, MIN_STEP, ContactEquilibrium3D, ContactProblem3D, solve_contact3d

__all__ = ["ContactEvent3D", "ContactPath3D", "contact_path3d"]

#: The most events located between two points of a path, per obstacle.
MAX_CHANGES = 8


@dataclass(frozen=True)
class ContactEvent3D:
    """``touch``, ``lift-off``, ``slide`` or ``lost`` (see the module's docstring) of obstacle ``obstacle``
    at ``pressure`` (MPa, within ``bracket``), at ``s`` (fraction of L; a slide's: where it arrives);
    ``before`` and ``after`` the places where the obstacle touches on either side."""

    kind: str
    obstacle: int
    pressure: float
    bracket: tuple[float, float]
    s: float
    before: tuple = ()
    after: tuple = ()

    def describe(self) -> str:
        move = ""
        if self.kind == "slide":
            move = f" from {' and '.join(self.before)} to {' and '.join(self.after)}"
        elif self.kind == "lost":
            move = f" (touching {' and '.join(self.before)}; no equilibrium in contact found beyond)"
        return (f"{self.kind} of obstacle #{self.obstacle + 1}{move} at s = {self.s:.3f}: P = {self.pressure:.6f} MPa "
                f"(bracket {self.bracket[1] - self.bracket[0]:.1e} MPa)")

    def to_dict(self) -> dict:
        return {"kind": self.kind, "obstacle": self.obstacle, "pressure_mpa": self.pressure, "bracket_mpa": list(self.bracket), "s": self.s,
                "before": list(self.before), "after": list(self.after), "description": self.describe()}


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

    def to_dict(self, shapes: bool = False) -> dict:
        """Every point (its contacts, KKT numbers, status; with ``shapes`` the joint rotations too) and every event."""
        points = []
        for p in self.points:
            d = p.to_dict()
            if not shapes:
                for key in ("theta_deg", "psi_deg", "tau_deg"):
                    d.pop(key)
            points.append(d)
        return {"parameter": "pressure", "pressures_mpa": list(self.pressures), "ok": self.ok, "points": points,
                "events": [e.to_dict() for e in self.events]}


def _places(r: ContactEquilibrium3D) -> dict[int, tuple]:
    """Per obstacle, where it touches: its contacts' places (``tip``, ``joint k``, ``inside segment i``), sorted along the length."""
    out: dict[int, list] = {k: [] for k in range(len(r.obstacles))}
    for c in sorted(r.contacts, key=lambda c: c.s):
        if c.where not in out[c.obstacle]:
            out[c.obstacle].append(c.where)
    return {k: tuple(v) for k, v in out.items()}


def _changes(scene: Scene, problem: ContactProblem3D, k: int, a: ContactEquilibrium3D, b: ContactEquilibrium3D, target: tuple,
             tol: float) -> list[ContactEvent3D]:
    """The changes of where obstacle k touches between two points of a path, each located by bisection
    (the first change between the last located one and b, until the places are b's); changes within 10 tol
    of each other are one event (a contact crossing a joint touches both segments there for an instant)."""
    out: list[ContactEvent3D] = []
    cur = a
    for _ in range(MAX_CHANGES):
        before = _places(cur)[k]
        if before == target:
            break
        lo, hi, lo_state, hi_state = cur.pressure, b.pressure, cur, b
        while abs(hi - lo) > tol:
            mid = 0.5 * (lo + hi)
            m = solve_contact3d(scene, problem=problem, pressure=mid, warm=lo_state)
            if not m.success:
                break
            if _places(m)[k] == before:
                lo, lo_state = mid, m
            else:
                hi, hi_state = mid, m
        arrived = _places(hi_state)[k]
        if out and abs(lo - out[-1].bracket[1]) <= 10 * tol and out[-1].kind in ("slide", "touch"):  # one event with the last
            first = out.pop()
            before, lo = first.before, first.bracket[0]
        kind = "touch" if not before else "lift-off" if not arrived else "slide"
        state = lo_state if kind == "lift-off" else hi_state
        where = [c.s for c in state.contacts if c.obstacle == k and (kind == "lift-off" or c.where not in before)] or \
                [c.s for c in state.contacts if c.obstacle == k]
        out.append(ContactEvent3D(kind, k, 0.5 * (lo + hi), (min(lo, hi), max(lo, hi)), where[0] if where else float("nan"), before, arrived))
        if hi_state is b or not hi_state.success:
            break
        cur = hi_state
    return out


def contact_path3d(scene: Scene, pressures: Sequence[float], section: Mapping[str, float] | None = None, options: ContactOptions | None = None, *,
                   tol: float = 1e-6, gravity_direction=None) -> ContactPath3D:
    """The 3-D equilibria of ``scene`` (with obstacles) at ``pressures`` (increasing or decreasing), the
    first from rest and each next one from the previous; touches, lift-offs and slides located to ``tol``
    MPa, and where the contact branch is lost."""
    pressures = tuple(float(p) for p in pressures)
    problem = ContactProblem3D(scene, section, gravity_direction, **({} if options is None else {"options": options}))
    points: list[ContactEquilibrium3D] = []
    events: list[ContactEvent3D] = []
    prev = None
    for p in pressures:
        r = solve_contact3d(scene, problem=problem, pressure=p, warm=prev) if prev is not None else solve_contact3d(scene, problem=problem, pressure=p)
        if prev is not None and r.status == LOST:  # the branch from prev ends at r.pressure, its last equilibrium
            step = MIN_STEP * abs(p - prev.pressure)
            ahead = r.pressure + (step if p > prev.pressure else -step)
            for k, where in _places(r).items():
                if where:
                    s = max(c.s for c in r.contacts if c.obstacle == k)
                    events.append(ContactEvent3D("lost", k, r.pressure, (min(r.pressure, ahead), max(r.pressure, ahead)), s, where, ()))
        elif prev is not None and r.success and prev.success:
            after = _places(r)
            for k in after:
                events += _changes(scene, problem, k, prev, r, after[k], tol)
        points.append(r)
        prev = r if r.success else None
    return ContactPath3D(pressures, tuple(points), tuple(events))
