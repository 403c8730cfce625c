"""The 3-D cases of ``docs/contact.md``: the planar contact as the restriction of the 3-D one, an obstacle
out of reach, a sideways wall against the dead load that holds the same shape, a sphere and a tilted
cylinder, random scenes, and the cost of a 3-D contact solve against a free 3-D solve.

Computation only (:mod:`esba.pages.contact3d` renders it).
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from esba.model.contact.obstacles import Cylinder, HalfPlane, ObstacleError
from esba.model.contact.spatial import Cylinder3D, Plane, Sphere
from esba.model.scene import Payload, Scene, SceneError
from esba.model.spatial import centreline3d
from esba.statics.contact import solve_contact
from esba.statics.contact.spatial import ContactEquilibrium3D, ContactProblem3D, solve_contact3d
from esba.statics.spatial import solve_scene3d

__all__ = ["Contact3DCases", "contact3d_cases", "SPHERE_SCENE", "TILTED_SCENE", "TIP_SLIDE_SCENE", "TIP_SLIDE_PRESSURES", "WALL_PAYLOAD", "RANDOM_SEEDS"]

#: A sphere inside the bend at 0.14 MPa, n = 3 (the example of esba.statics.contact.spatial).
SPHERE_SCENE = Scene(pressure=0.14, obstacles=(Sphere(centre=(66.0, 52.0, 3.0), radius=10.0),))
#: The finger at 0.2 MPa, n = 8, against a cylinder of radius 15 mm about (70, 45, 0) whose axis leans
#: out of the plane across the bend, (0, 0.5, 1).
TILTED_SCENE = Scene(segments=8, pressure=0.2, obstacles=(Cylinder3D(centre=(70.0, 45.0, 0.0), axis=(0.0, 0.5, 1.0), radius=15.0),))
#: The off-plane tip load of the wall case: 0.3 N straight out of the plane (Beta = 90 deg), at 90 deg target angle.
WALL_PAYLOAD = Payload(0.3, 90.0, 1.0, 90.0)
#: A cylinder of tilted axis beside the tip (the obstacle of random scene 30, rounded): as the pressure falls
#: from 0.095 to 0.065 MPa the contact slides from inside segment 3 onto the rounded tip, then lifts off.
TIP_SLIDE_SCENE = Scene(pressure=0.09, obstacles=(Cylinder3D(centre=(91.4, 51.3, 6.4), axis=(-0.934, -0.173, 0.312), radius=11.5),))
#: The pressures of the path through that slide, MPa (falling).
TIP_SLIDE_PRESSURES = tuple(float(p) for p in np.linspace(0.095, 0.065, 7))
#: The pressures of the 3-D path (the sphere scene), MPa.
PATH_PRESSURES = tuple(float(p) for p in np.linspace(0.0, 0.2, 11))
#: The seeds of the random scenes (tests/statics/test_contact3d.py solves the same ones).
RANDOM_SEEDS = tuple(range(11, 19)) + tuple(range(20, 32))


@dataclass(frozen=True, eq=False)
class Contact3DCases:
    """Everything the page's 3-D section shows."""

    restriction: list[tuple[str, int, float, float, float]]  # case, contacts, max |d theta|, max |d force|, max |psi|, |tau|
    out_of_reach: tuple[float, float]                        # least gap, max |q - q_free|
    wall: tuple[float, float, float, float]                  # free tip z, wall z, force, max |q - q_dead|
    sphere: ContactEquilibrium3D
    tilted: ContactEquilibrium3D
    # seed, kind, ok, contacts, stationarity, complementarity, least gap, status, reached, least reduced eigenvalue
    random: list[tuple[int, str, bool, int, float, float, float, str, tuple, float]]
    costs: list[tuple[str, float]]
    ratio: float
    path: object = None  # esba.statics.contact.spatial_path.ContactPath3D of the sphere scene, 0 to 0.2 MPa
    tip_path: object = None  # the same of TIP_SLIDE_SCENE at TIP_SLIDE_PRESSURES: the contact slides onto the tip


def random_scene(rng: np.random.Generator) -> Scene:
    """A random pressure and off-plane payload, and a sphere, a plane or a tilted cylinder placed 1 to
    6 mm into the free shape at a random point (redrawn while it reaches into the actuator at rest)."""
    while True:
        payload = Payload(rng.uniform(0.0, 0.4), rng.uniform(0.0, 180.0), rng.uniform(0.5, 1.0), rng.uniform(-90.0, 90.0))
        scene = Scene(pressure=rng.uniform(0.04, 0.18), payloads=(payload,))
        free = solve_scene3d(scene)
        pts, _ = centreline3d(3, free.q, 135.0, 4)
        target = pts[rng.integers(4, len(pts))]
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        depth, radius, kind = rng.uniform(1.0, 6.0), rng.uniform(5.0, 20.0), rng.integers(3)
        try:
            if kind == 0:
                o = Sphere(centre=tuple(target + u * (radius - depth)), radius=radius)
            elif kind == 1:
                o = Plane(at=tuple(target - u * depth), normal=tuple(u))
            else:
                a = rng.normal(size=3)
                a -= (a @ u) * u
                o = Cylinder3D(centre=tuple(target + u * (radius - depth)), axis=tuple(a), radius=radius)
            return scene.replace(obstacles=(o,))
        except (ObstacleError, SceneError):
            continue


def _median(fn: Callable[[], object], repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def contact3d_cases(progress: Callable[[str], None] | None = None) -> Contact3DCases:
    """Run every 3-D case of the page (about a minute)."""
    say = progress or (lambda msg: None)
    restriction = []
    for name, pressure, planar, spatial in (
        ("probe at the tip (plane, normal in the bending plane, the layer)", 0.1, HalfPlane(at=(135.0, 0.0)),
         Plane(at=(135.0, 0.0, 0.0), normal=(0.0, -1.0, 0.0), side="inner")),
        ("cylinder across the plane (axis z, the tube)", 0.14, Cylinder(centre=(90.0, 40.0), radius=12.0),
         Cylinder3D(centre=(90.0, 40.0, 0.0), axis=(0.0, 0.0, 1.0), radius=12.0)),
    ):
        flat = solve_contact(Scene(pressure=pressure, obstacles=(planar,)))
        r = solve_contact3d(Scene(pressure=pressure, obstacles=(spatial,)))
        dforce = max(abs(a.force - b.force) for a, b in zip(r.contacts, flat.contacts))
        restriction.append((name, len(r.contacts), float(np.max(np.abs(r.theta - flat.theta))), dforce, float(np.max(np.abs(r.q[3:])))))
    say("restriction")
    base = Scene(payloads=(WALL_PAYLOAD,))
    free = solve_scene3d(base)
    far = solve_contact3d(base.replace(obstacles=(Sphere(centre=(0.0, 0.0, 300.0), radius=20.0),)))
    out_of_reach = (float(far.gaps[0]), float(np.max(np.abs(far.q - free.q))))
    wall_z = 0.6 * float(free.tip[2])
    wall = solve_contact3d(base.replace(obstacles=(Plane(at=(0.0, 0.0, wall_z), normal=(0.0, 0.0, -1.0), side="inner"),)))
    f = wall.contacts[0].force
    dead = solve_scene3d(base.replace(payloads=(WALL_PAYLOAD, Payload(f, 0.0, 1.0, -90.0))))
    wall_case = (float(free.tip[2]), wall_z, f, float(np.max(np.abs(dead.q - wall.q))))
    say("wall")
    sphere = solve_contact3d(SPHERE_SCENE)
    tilted = solve_contact3d(TILTED_SCENE)
    say("sphere, tilted cylinder")
    rows = []
    for seed in RANDOM_SEEDS:
        scene = random_scene(np.random.default_rng(seed))
        r = solve_contact3d(scene)
        k = r.kkt
        rows.append((seed, scene.obstacles[0].kind, r.ok, len(r.contacts), k.stationarity, k.complementarity, k.min_gap, r.status, r.reached,
                     float(k.reduced_eigenvalues[0]) if k.reduced_eigenvalues.size else float("nan")))
    say("random scenes")
    from esba.statics.contact.spatial_path import contact_path3d

    path = contact_path3d(SPHERE_SCENE, PATH_PRESSURES)
    tip_path = contact_path3d(TIP_SLIDE_SCENE, TIP_SLIDE_PRESSURES)
    say("paths")
    problem = ContactProblem3D(SPHERE_SCENE)
    solve_contact3d(SPHERE_SCENE, problem=problem)  # built and warmed once: the medians are solves
    free_scene = SPHERE_SCENE.replace(obstacles=())
    solve_scene3d(free_scene)
    free_s = _median(lambda: solve_scene3d(free_scene))
    costs = [
        ("free 3-D solve of the same actuator (esba.statics.spatial.solve_scene3d: load history, IPOPT certificate)", free_s),
        ("3-D contact solve from rest, the sphere (esba.statics.contact.spatial.solve_contact3d)", _median(lambda: solve_contact3d(SPHERE_SCENE, problem=problem))),
        ("planar contact solve of the probe at the tip (esba.statics.contact.solve_contact), for scale",
         _median(lambda: solve_contact(Scene(pressure=0.1, obstacles=(HalfPlane(at=(135.0, 0.0)),))))),
    ]
    say("costs")
    return Contact3DCases(restriction, out_of_reach, wall_case, sphere, tilted, rows, costs, costs[1][1] / free_s, path, tip_path)
