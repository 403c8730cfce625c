"""The cases of ``docs/contact.md``: the blocked-force curve, the probe against a dead load, the tester
through the snap, the finger closing on a cylinder, the cost of contact against a free solve, and the
3-D cases (:mod:`.contact3d_cases`).

Computation only (:mod:`esba.pages.contact` renders it).
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from esba.model.contact.obstacles import Cylinder, HalfPlane
from esba.model.scene import Payload, Scene
from esba.statics.contact import ContactOptions, solve_contact
from esba.statics.contact.sweeps import ContactPath, ForceRamp, blocked_force, displacement_path, force_ramp, grasp
from esba.statics.equilibrium import SolverOptions, solve

__all__ = ["ContactCases", "contact_cases", "TESTER_PRESSURE", "CYLINDER", "PRESSURES"]

#: The pressures of the blocked-force curve and of the grasp, MPa.
PRESSURES = tuple(float(p) for p in np.linspace(0.0, 0.3, 31))
#: The tester's pressure: inside the bistable window of the 2 N case (0.1636 to 0.1735 MPa, docs/paths.md).
TESTER_PRESSURE = 0.17
#: The tester's prescribed tip y, mm.
TESTER_Y = tuple(float(y) for y in np.arange(20.0, 95.01, 0.5))
#: The cylinder the finger closes on: centre (mm), radius (mm).
CYLINDER = ((70.0, 45.0), 15.0)


@dataclass(frozen=True, eq=False)
class ContactCases:
    """Everything the page shows."""

    blocked: ContactPath
    dead_load: list[tuple[int, float, float, float]]
    tester: ContactPath
    ramp_down: ForceRamp
    ramp_up: ForceRamp
    grasp: ContactPath
    costs: list[tuple[str, float]]
    ratio: float
    spatial: Any = None  # esba.analysis.contact3d_cases.Contact3DCases: the page's 3-D section


def _median(fn: Callable[[], object], repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def contact_cases(progress: Callable[[str], None] | None = None) -> ContactCases:
    """Run every case of the page (about a minute)."""
    say = progress or (lambda msg: None)
    step = SolverOptions(multistability="never")
    blocked = blocked_force(Scene(segments=8), PRESSURES)
    say("blocked-force curve")
    dead = []
    for n in (1, 3, 8):
        for p in (0.1, 0.3):
            r = solve_contact(Scene(segments=n, pressure=p, obstacles=(HalfPlane(at=(135.0, 0.0)),)))
            f = r.contacts[0].force
            free = solve(Scene(segments=n, pressure=p, payloads=(Payload(f, 90.0, 1.0),)), step, theta0=r.theta)
            dead.append((n, p, f, float(np.max(np.abs(free.theta - r.theta)))))
    say("probe against dead load")
    tester = displacement_path(Scene(segments=3), TESTER_PRESSURE, TESTER_Y)
    ramp_down = force_ramp(Scene(segments=3), TESTER_PRESSURE, np.linspace(-tester.points[0].reaction[1], 0.0, 137), theta0=tester.points[0].theta)
    ramp_up = force_ramp(Scene(segments=3), TESTER_PRESSURE, np.linspace(0.0, 3.0, 76))
    say("tester")
    g = grasp(Scene(segments=8), CYLINDER[0], CYLINDER[1], PRESSURES)
    say("grasp")
    probe_scene = Scene(segments=3, pressure=0.1, obstacles=(HalfPlane(at=(135.0, 0.0)),))
    ref = solve_contact(probe_scene)
    twin = Scene(segments=3, pressure=0.1, payloads=(Payload(ref.contacts[0].force, 90.0, 1.0),))
    free_s = _median(lambda: solve(twin, step))
    costs = [
        ("free solve of the dead-load twin (esba.solve)", free_s),
        ("contact solve from rest (active-set Newton, IPOPT where it fails)", _median(lambda: solve_contact(probe_scene))),
        ("contact solve from rest, IPOPT only", _median(lambda: solve_contact(probe_scene, ContactOptions(newton=False)))),
        ("blocked-force curve, n = 8, 31 pressures", _median(lambda: blocked_force(Scene(segments=8), PRESSURES), 3)),
    ]
    say("costs")
    from .contact3d_cases import contact3d_cases

    spatial = contact3d_cases(say)
    return ContactCases(blocked, dead, tester, ramp_down, ramp_up, g, costs, costs[1][1] / free_s, spatial)
