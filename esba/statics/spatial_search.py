"""Every equilibrium of a scene in 3-D: deflated Newton in the 3n unknowns, from many starts.

The planar search (:mod:`esba.statics.equilibria`) stands on the chain's O(n) Hessian structure;
this one is dense (3n x 3n) and otherwise the same method: Newton's method on the deflated
residual G(q) = M(q) dU/dq, M(q) = prod_k (1 / |q - q*_k|^2 + 1), whose step is the ordinary
Newton step delta = -H^-1 g scaled by 1 / (1 - (grad log M) . delta) (Farrell, Birkisson and
Funke, SIAM J. Sci. Comput. 37(4), 2015), so that a start cannot land on an equilibrium already found.

**The starts**, in order: the load-history state (:func:`esba.statics.spatial.solve3d`); every
planar equilibrium of the in-plane part of the scene (:func:`esba.statics.equilibria.equilibria`,
the payloads turned into the plane), with no sideways bend and no twist, and each of them moved
both ways along every Hessian mode of negative curvature (where an in-plane state is unstable
sideways, the states it falls to lie that way); then a grid of ``starts`` in-plane total bends
over the domain, each with no sideways bend and with a sideways bend of +-30 degrees, with a twist
of 0 and +-90 degrees.

**The domain**: each in-plane angle above the model's lower bound (Eq. 10: the chamber closes) and
each joint's sideways bend within +-90 degrees and its twist within +-180 degrees; each Newton step moves every unknown by
at most 0.3 rad. A start converging outside is counted (``outside``), not listed.

**Each equilibrium**: its energy, tip (x, y, z), in-plane bend, sideways bend and twist, the
Hessian's eigenvalues and Morse index (its number of negative eigenvalues), stable when the Morse
index is 0 and no eigenvalue lies within 1e-9 of the largest of zero. ``certified``: the gradient
is below 1e-9 of the Hessian's largest entry, the Hessian is regular there (an isolated
equilibrium), and for a stable state IPOPT run from it stays on it (to 1e-8 rad).

**The completeness check**: a second search from the grid shifted half a step, deflated by all
found; ``complete`` says it found nothing new.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from esba.infra.threads import single_threaded
from esba.model.spatial import Model3D, load_model3d

from .spatial import SpatialError, _bounds, _ipopt, scene_values3d, solve3d

__all__ = ["search3d", "Equilibria3D", "SpatialState", "search3d_table", "DEFAULT_STARTS_3D"]

#: In-plane total bends of the grid of starts.
DEFAULT_STARTS_3D = 8
#: Largest sideways bend of a joint searched (rad).
SIDE_LIMIT = math.pi / 2
#: Largest twist of a joint searched (rad): a soft section twists far (the paper's actuator flipped
#: sideways under 2 N twists 112 degrees in its first joint).
TWIST_LIMIT = math.pi
#: Largest change of an unknown in one Newton step (rad).
MAX_STEP = 0.3
#: Newton iterations per start.
MAX_ITER = 80
#: Two equilibria closer than this (rad, largest unknown) are one.
SAME = 1e-7


@dataclass
class SpatialState:
    q: np.ndarray
    n: int
    energy: float
    eigenvalues: np.ndarray
    tip: np.ndarray
    gradient_norm: float
    certified: bool
    found: str

    @property
    def morse_index(self) -> int:
        w = self.eigenvalues
        return int(np.sum(w < -1e-9 * max(1.0, float(np.max(np.abs(w))))))

    @property
    def stable(self) -> bool:
        w = self.eigenvalues
        return self.morse_index == 0 and bool(w[0] > 1e-9 * max(1.0, float(np.max(np.abs(w)))))

    @property
    def in_plane(self) -> bool:
        return bool(np.all(self.q[self.n:] == 0.0))

    @property
    def stability(self) -> str:
        if self.stable:
            return "stable"
        return "critical" if self.morse_index == 0 else f"unstable (index {self.morse_index})"

    def angles_deg(self) -> tuple[float, float, float]:
        n = self.n
        return tuple(math.degrees(float(np.sum(self.q[k * n:(k + 1) * n]))) for k in range(3))  # type: ignore[return-value]

    def to_dict(self) -> dict[str, Any]:
        bend, side, twist = self.angles_deg()
        n = self.n
        return {
            "theta_deg": np.degrees(self.q[:n]).tolist(), "psi_deg": np.degrees(self.q[n:2 * n]).tolist(), "tau_deg": np.degrees(self.q[2 * n:]).tolist(),
            "in_plane_deg": bend, "sideways_deg": side, "twist_deg": twist, "in_plane": self.in_plane,
            "tip_mm": [float(v) for v in self.tip], "energy_nmm": self.energy, "morse_index": self.morse_index,
            "min_eigenvalue": float(self.eigenvalues[0]), "stable": self.stable, "stability": self.stability,
            "gradient_norm": self.gradient_norm, "certified": self.certified, "found": self.found,
        }


@dataclass
class Equilibria3D:
    scene: Any
    model: str
    section: dict
    states: list[SpatialState]
    complete: bool | None
    check_found: int
    starts: int
    runs: int
    outside: int
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene.describe(), "model": self.model, "three_d": True, "section_nmm2": self.section,
            "states": [s.to_dict() for s in self.states], "complete": self.complete, "check_found": self.check_found,
            "starts": self.starts, "runs": self.runs, "outside": self.outside,
            "multistable": sum(s.stable for s in self.states) > 1, "notes": self.notes,
        }


class _Search:
    def __init__(self, model: Model3D, values: Mapping[str, float]):
        self.model = model
        self.values = dict(values)
        self.p = model.param_vector(values)
        self.fun = model.state_function()
        self.lb = _bounds(model, values)
        self.found: list[np.ndarray] = []
        self.sources: list[str] = []
        self.outside = 0
        self.runs = 0

    def state(self, q):
        _, g, h = self.fun(q, self.p)
        return np.asarray(g).ravel(), np.asarray(h)

    def inside(self, q) -> bool:
        n = self.model.n
        return bool(np.all(q > self.lb) and np.all(np.abs(q[n:2 * n]) <= SIDE_LIMIT) and np.all(np.abs(q[2 * n:]) <= TWIST_LIMIT) and np.all(np.isfinite(q)))

    def run(self, q0: np.ndarray, deflate: bool = True) -> np.ndarray | None:
        """Deflated Newton from q0: the equilibrium reached (polished, undeflated), or None."""
        self.runs += 1
        q = np.array(q0, dtype=float)
        if not np.all(q > self.lb):
            q = np.maximum(q, self.lb + 1e-3)
        for _ in range(MAX_ITER):
            g, h = self.state(q)
            scale = max(1.0, float(np.abs(h).max()))
            if float(np.abs(g).max()) <= 1e-10 * scale:
                return self.polish(q)
            try:
                delta = -np.linalg.solve(h, g)
            except np.linalg.LinAlgError:
                delta = -np.linalg.lstsq(h, g, rcond=None)[0]
            if deflate and self.found:
                grad = np.zeros_like(q)
                for f in self.found:
                    d = q - f
                    r2 = float(d @ d)
                    grad += -2.0 * d / (r2 * r2) / (1.0 / r2 + 1.0) if r2 > 0 else 0.0
                denom = 1.0 - float(grad @ delta)
                if abs(denom) > 1e-12:
                    delta = delta / denom
            big = float(np.abs(delta).max())
            if not math.isfinite(big):
                return None
            if big > MAX_STEP:
                delta *= MAX_STEP / big
            t = 1.0
            while not np.all(q + t * delta > self.lb) and t > 1e-6:
                t *= 0.5
            q = q + t * delta
            n = self.model.n
            if np.any(np.abs(q[n:2 * n]) > 2 * SIDE_LIMIT) or np.any(np.abs(q[2 * n:]) > 2 * TWIST_LIMIT):
                return None
        return None

    def polish(self, q: np.ndarray) -> np.ndarray:
        for _ in range(4):
            g, h = self.state(q)
            try:
                step = -np.linalg.solve(h, g)
            except np.linalg.LinAlgError:
                break
            if float(np.abs(step).max()) < 1e-15 or not np.all(q + step > self.lb):
                break
            q = q + step
        return q

    def add(self, q: np.ndarray | None, source: str) -> bool:
        """Keep a new equilibrium; True when it is new and inside the domain."""
        if q is None:
            return False
        if any(np.abs(q - f).max() < SAME for f in self.found):
            return False
        if not self.inside(q):
            self.outside += 1
            return False
        self.found.append(q)
        self.sources.append(source)
        return True


def _grid(n: int, lower: float, starts: int, shift: float) -> list[np.ndarray]:
    low = max(n * lower, -math.radians(120.0)) if math.isfinite(lower) else -math.radians(120.0)
    high = math.radians(330.0)
    totals = low + (high - low) * (np.arange(starts) + 0.5 + shift) / (starts + 0.5)
    out = []
    for total in totals:
        for side in (0.0, math.radians(30.0), -math.radians(30.0)):
            for twist in (0.0, math.radians(90.0), -math.radians(90.0)):
                out.append(np.concatenate([np.full(n, total / n), np.full(n, side / n), np.full(n, twist / n)]))
    return out


@single_threaded
def search3d(scene, section: Mapping[str, float] | None = None, *, gravity_direction=None, starts: int | None = None, check: bool = True) -> Equilibria3D:
    """Every equilibrium of ``scene`` in 3-D that the search finds (see the module)."""
    from esba.statics.equilibria import EquilibriaOptions, equilibria

    starts = DEFAULT_STARTS_3D if starts is None else starts
    if isinstance(starts, bool) or not isinstance(starts, int) or not 2 <= starts <= 1000:
        raise SpatialError(f"starts={starts!r}: expected a whole number from 2 to 1000")
    effects, values = scene_values3d(scene, section, scene.down(gravity_direction))
    model = load_model3d(scene.segments, effects, scene.variant)
    n = model.n
    s = _Search(model, values)
    notes: list[str] = []
    # 1. the load history's state
    first = solve3d(model, values, certify=False)
    s.add(s.run(first.q, deflate=False) if first.converged else None, "load history")
    # 2. the planar equilibria of the in-plane part, and their sideways modes
    from dataclasses import replace

    flat = scene.replace(payloads=tuple(replace(p, out_of_plane_deg=0.0) for p in scene.payloads)) if scene.needs_3d else scene
    planar_states = []
    if not scene.obstacles:
        try:
            planar_states = [st.theta for st in equilibria(flat, EquilibriaOptions(check=False)).states]
        except Exception as exc:  # the planar search is only a source of starts here
            notes.append(f"the planar search gave no starts: {exc}")
    for theta in planar_states:
        q = np.concatenate([theta, np.zeros(2 * n)])
        s.add(s.run(q), "planar")
        _, h = s.state(q)
        w, V = np.linalg.eigh(h)
        for k in np.flatnonzero(w < 0):
            mode = V[:, k] / np.abs(V[:, k]).max()
            for sign in (1.0, -1.0):
                s.add(s.run(q + sign * 0.05 * mode), "unstable mode")
    # 3. the grid, in rounds until one finds nothing new
    lower = float(s.lb[0]) if math.isfinite(s.lb[0]) else -math.inf
    grid = _grid(n, lower, starts, 0.0)
    for _ in range(4):
        new = sum(s.add(s.run(q0), "grid") for q0 in grid)
        if not new:
            break
    complete, check_found = None, 0
    if check:
        check_found = sum(s.add(s.run(q0), "completeness check") for q0 in _grid(n, lower, starts, 0.5))
        complete = check_found == 0
    out = []
    for q, source in zip(s.found, s.sources):
        g, h = s.state(q)
        w = np.linalg.eigvalsh(h)
        scale = max(1.0, float(np.abs(h).max()))
        gn = float(np.abs(g).max())
        certified = gn <= 1e-9 * scale and float(np.min(np.abs(w))) > 1e-9 * float(np.max(np.abs(w)))
        if certified and w[0] > 0:
            qi, status = _ipopt(model, values, q, s.lb)
            certified = status == "Solve_Succeeded" and float(np.abs(qi - q).max()) <= 1e-8
        out.append(SpatialState(q, n, model.energy(q, values), w, model.tip(q, values["L"]), gn, bool(certified), source))
    out.sort(key=lambda st: (round(st.energy, 9), round(float(st.tip[2]), 9)))
    sec = {k: float(values[k]) for k in ("EI_side", "GJ")}
    return Equilibria3D(scene, model.path.name, sec, out, complete, check_found, len(grid), s.runs, s.outside, notes)


def search3d_table(d: dict) -> str:
    """The text ``esba equilibria --3d`` prints."""
    lines = [f"scene: {d['scene']} (3-D: {d['model']}; EI_side {d['section_nmm2']['EI_side']:.6g}, GJ {d['section_nmm2']['GJ']:.6g} N mm^2)",
             f"{len(d['states'])} equilibria ({d['runs']} Newton runs from {d['starts']} grid starts and the in-plane states; "
             + ("complete: the check from fresh starts found nothing new" if d["complete"] else
                "NOT complete: the check found more (raise --starts)" if d["complete"] is False else "no completeness check") + ")",
             f"  {'#':>2}  {'stability':<20} {'in-plane':>9} {'sideways':>9} {'twist':>8} {'tip x, y, z mm':>26} {'energy N mm':>12}  certified  found"]
    for k, s in enumerate(d["states"], start=1):
        tip = ", ".join(f"{v:7.2f}" for v in s["tip_mm"])
        lines.append(f"  {k:>2}  {s['stability']:<20} {s['in_plane_deg']:9.3f} {s['sideways_deg']:9.3f} {s['twist_deg']:8.3f} {tip:>26} {s['energy_nmm']:12.4f}  "
                     f"{'yes' if s['certified'] else 'NO':<9}  {s['found']}")
    if d["outside"]:
        lines.append(f"{d['outside']} Newton runs ended outside the domain searched (a joint's sideways bend beyond 90 deg or its twist beyond 180 deg, or the chamber closed)")
    lines += [f"note: {n}" for n in d["notes"]]
    return "\n".join(lines)
