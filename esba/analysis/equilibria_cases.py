"""The cases of ``docs/equilibria.md``: every equilibrium of the Table 1 actuator where it is
multistable. This module computes; :mod:`esba.pages.equilibria` renders.

:func:`equilibria_cases` finds (with :func:`esba.statics.equilibria.equilibria`):

* the bistable window under the 2 N horizontal tip payload (Table 2's load): every equilibrium at
  pressures across it, the barriers, and the state each load history reaches (``solve``);
* the same window for n = 3, 8, 16, 32: the same equilibria as n grows;
* the payload direction Omega = 121 deg at the 90 degree pressure (2 N): the two stable states and
  the payload range of the branch through the strongly curled one (a trace in the payload from
  2 N both ways, :func:`esba.paths.continuation.trace`), which shows that it never reaches F = 0;
* the straight column (P = 0) under a 3 N push, between its fold and its buckling load.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from esba.model.scene import Payload, Scene
from esba.paths.continuation import PathOptions, PathProblem, trace
from esba.statics.equilibria import Equilibria, equilibria
from esba.statics.equilibrium import SolverOptions, solve
from esba.statics.history import HISTORIES

__all__ = ["EquilibriaCases", "equilibria_cases", "WINDOW_PRESSURES", "WINDOW_NS", "OMEGA_DEG", "PAYLOAD_RANGE_N"]

#: Pressures across the bistable window under 2 N (folds at 0.1636 and 0.1735 MPa for n = 3), MPa.
WINDOW_PRESSURES = (0.165, 0.1686, 0.17, 0.173)
#: Segment counts of the window at 0.17 MPa.
WINDOW_NS = (3, 8, 16, 32)
#: The payload direction of the detached branch, deg from the vertical.
OMEGA_DEG = 121.0
#: The payload range the branch through the curled state is traced in, N.
PAYLOAD_RANGE_N = (0.0, 8.0)

TWO_N = (Payload(2.0, 90.0),)


@dataclass(frozen=True, eq=False)
class EquilibriaCases:
    """What :func:`equilibria_cases` found.

    ``window``: per pressure, the equilibria and, per history name, the total bend ``solve`` reaches;
    ``by_n``: the equilibria at 0.17 MPa per n; ``direction``: the equilibria at Omega = 121 deg and
    the 90 degree pressure; ``curled``: the payload range (min, max, N) of the branch through its
    curled stable state and the folds on it (N, total bend deg); ``column``: the straight column
    under 3 N.
    """

    window: tuple[tuple[Equilibria, dict[str, float]], ...]
    by_n: tuple[Equilibria, ...]
    direction: Equilibria
    curled: dict[str, Any]
    column: Equilibria


def _histories(scene: Scene) -> dict[str, float]:
    out = {}
    for name in HISTORIES:
        r = solve(scene, SolverOptions(history=name, multistability="never"))
        out[name] = r.total_angle_deg if r.ok else float("nan")
    return out


def equilibria_cases(progress: Callable[[str], None] | None = None) -> EquilibriaCases:
    """Every case of the page (see the module); a few seconds."""
    say = progress or (lambda msg: None)
    window = []
    for p in WINDOW_PRESSURES:
        scene = Scene(pressure=p, payloads=TWO_N)
        window.append((equilibria(scene), _histories(scene)))
        say(f"the window at {p} MPa")
    by_n = []
    for n in WINDOW_NS:
        by_n.append(equilibria(Scene(pressure=0.17, payloads=TWO_N, segments=n)))
        say(f"the window at 0.17 MPa, n = {n}")
    direction = equilibria(Scene(target_angle_deg=90.0, payloads=(Payload(2.0, OMEGA_DEG),)))
    curled_state = max(direction.stable, key=lambda s: s.total_angle_deg)
    problem = PathProblem.from_scene(Scene(pressure=direction.pressure, payloads=(Payload(2.0, OMEGA_DEG),)), "payload")
    lows, highs, folds = [], [], []
    for way in (1.0, -1.0):
        b = trace(problem, curled_state.theta, 2.0, bounds=PAYLOAD_RANGE_N, direction=way, options=PathOptions(ds_max=0.1))
        lows.append(float(b.lam.min()))
        highs.append(float(b.lam.max()))
        folds += [(sp.lam, sp.total_angle_deg) for sp in b.folds]
    curled = {"min_n": min(lows), "max_n": max(highs), "folds": sorted(folds), "total_angle_deg": curled_state.total_angle_deg}
    say("the payload direction at 121 deg")
    column = equilibria(Scene(pressure=0.0, payloads=(Payload(3.0, 180.0),)))
    say("the column")
    return EquilibriaCases(tuple(window), tuple(by_n), direction, curled, column)

