"""Contact: the constrained equilibrium against what it must equal, its KKT conditions, its events."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from esba.model.contact import Cylinder, HalfPlane, ObstacleError
from esba.model.contact.surface import closest_points, surface_points, symbolic_surface
from esba.model.scene import Payload, Scene, SceneError, scene_from_dict
from esba.statics.contact import Displacement, solve_contact
from esba.statics.contact.sweeps import blocked_force, contact_path, displacement_path, grasp
from esba.statics.equilibrium import SolverOptions, solve

#: the probe at the tip against a dead load of the contact force's size (the issue's own bound)
DEAD_LOAD_THETA = 1e-9
#: KKT numbers of a converged contact solve (IPOPT tol 1e-10, then Newton on the active set)
KKT_STATIONARITY = 1e-7  # N mm/rad
KKT_COMPLEMENTARITY = 1e-8  # N mm
KKT_FORCE = -1e-8  # N
KKT_GAP = -1e-7  # mm

STEP = SolverOptions(multistability="never")


@pytest.mark.parametrize("n", [1, 3, 8])
def test_probe_at_the_tip_is_a_horizontal_dead_load(n):
    probe = HalfPlane(at=(135.0, 0.0), normal_deg=90.0)
    r = solve_contact(Scene(segments=n, pressure=0.15, obstacles=(probe,)))
    assert r.ok, r.message
    assert [c.where for c in r.contacts] == ["tip"]
    c = r.contacts[0]
    assert c.direction == (0.0, -1.0) and c.force > 0
    free = solve(Scene(segments=n, pressure=0.15, payloads=(Payload(c.force, 90.0, 1.0),)), STEP, theta0=r.theta)
    assert free.ok
    assert np.max(np.abs(free.theta - r.theta)) <= DEAD_LOAD_THETA
    assert abs(r.tip[1]) <= 1e-12  # held on the probe's face


def _random_scene(rng, n):
    """A cylinder or a tilted wall on the bending side, clear of the actuator at rest (drawn again when not)."""
    while True:
        if rng.random() < 0.5:
            obstacle = Cylinder(centre=(rng.uniform(40.0, 110.0), rng.uniform(25.0, 70.0)), radius=rng.uniform(5.0, 20.0))
        else:
            obstacle = HalfPlane(at=(135.0, rng.uniform(0.0, 60.0)), normal_deg=90.0 + rng.uniform(-30.0, 30.0))
        try:
            return Scene(segments=n, pressure=rng.uniform(0.05, 0.3), obstacles=(obstacle,))
        except ObstacleError:
            continue


@pytest.mark.parametrize("seed", range(6))
def test_complementarity_on_random_scenes(seed):
    rng = np.random.default_rng(seed)
    scene = _random_scene(rng, int(rng.choice([2, 3, 5])))
    r = solve_contact(scene)
    assert r.success, (scene.describe(), r.message)
    k = r.kkt
    assert k.stationarity <= KKT_STATIONARITY
    assert k.complementarity <= KKT_COMPLEMENTARITY
    assert k.min_force >= KKT_FORCE
    assert k.min_gap >= KKT_GAP
    # no penetration anywhere along the body, on a fine sample
    o = scene.obstacles[0]
    q = surface_points(r.theta, 135.0, 0.0 if o.resolved_side() == "inner" else 16.0, np.tile(np.linspace(0, 1, 401), (scene.segments, 1)))
    assert float(np.min(o.distance(q))) >= KKT_GAP
    for c in r.contacts:
        assert c.force >= 0 and abs(c.gap) <= 1e-7


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6, 7, 8])
def test_the_readme_cylinder_is_solved_at_every_segment_count(n):
    # the closest point on the touching segment used to cycle between passes (at n = 5 and 7, 0.3 MPa):
    # the state constrained near the joint dipped into the cylinder half-way along the segment, and back
    scene = Scene(segments=n, pressure=0.3, obstacles=(Cylinder(centre=(70.0, 45.0), radius=15.0),))
    r = solve_contact(scene)
    assert r.ok, r.message
    k = r.kkt
    assert k.stationarity <= KKT_STATIONARITY and k.complementarity <= KKT_COMPLEMENTARITY
    assert k.min_force >= KKT_FORCE and k.min_gap >= KKT_GAP
    q = surface_points(r.theta, 135.0, 0.0, np.tile(np.linspace(0, 1, 401), (n, 1)))
    assert float(np.min(scene.obstacles[0].distance(q))) >= KKT_GAP
    assert len(r.contacts) == 1 and 7.4 < r.contacts[0].force < 9.1


def test_a_cylinder_out_of_reach_gives_the_free_solution():
    scene = Scene(segments=3, pressure=0.12, obstacles=(Cylinder(centre=(60.0, -150.0), radius=10.0),))
    r = solve_contact(scene)
    free = solve(scene.replace(obstacles=()), STEP)
    assert r.ok and r.contacts == ()
    assert np.max(np.abs(r.theta - free.theta)) <= 1e-9
    assert r.gaps[0] > 50.0


def test_solve_dispatches_to_contact():
    scene = Scene(segments=3, pressure=0.1, obstacles=(HalfPlane(at=(135.0, 0.0)),))
    r = solve(scene)
    assert r.ok and r.contact is not None and [c.where for c in r.contact.contacts] == ["tip"]
    assert r.history.startswith("inflate-then-load with contact")
    again = solve(scene, theta0=r.theta)  # a warm start at the full load
    assert np.max(np.abs(again.theta - r.theta)) <= 1e-12 and again.history.startswith("none")


def test_reduced_hessian_is_the_free_hessian_without_contact():
    scene = Scene(segments=3, pressure=0.12, obstacles=(Cylinder(centre=(60.0, -150.0), radius=10.0),))
    r = solve_contact(scene)
    free = solve(scene.replace(obstacles=()), STEP)
    assert np.allclose(r.kkt.reduced_eigenvalues, free.eigenvalues, rtol=1e-8)


def test_displacement_reaction_is_the_dead_load_that_holds_it():
    r = solve_contact(Scene(segments=3, pressure=0.17), displacement=Displacement(y=80.0))
    assert r.ok and abs(r.tip[1] - 80.0) <= 1e-9
    force = -r.reaction[1]
    free = solve(Scene(segments=3, pressure=0.17, payloads=(Payload(force, 90.0, 1.0),)), STEP, theta0=r.theta)
    assert np.max(np.abs(free.theta - r.theta)) <= DEAD_LOAD_THETA


def test_a_reachable_looking_target_without_equilibrium_fails_with_no_reaction():
    r = solve_contact(Scene(segments=3, pressure=0.17), displacement=Displacement(x=134.0, y=16.0))  # within L, past the bend's reach
    assert not r.ok and not r.success and r.reaction is None
    assert "IPOPT did not converge" in r.message and "no reaction" in r.message
    assert r.to_dict()["reaction_n"] is None


def test_blocked_force_grows_and_stays_at_the_tip():
    b = blocked_force(Scene(segments=3), [0.0, 0.1, 0.2, 0.3])
    assert b.ok
    assert b.forces[0] == 0.0 and all(np.diff(b.forces) > 0)
    assert all([c.where for c in p.contacts] == ["tip"] for p in b.points[1:])
    # the S: bent away from the probe at the base, towards it at the tip
    last = b.points[-1].theta
    assert last[0] < 0 < last[-1]


def test_grasp_first_touch_is_located():
    g = grasp(Scene(segments=3), (70.0, 45.0), 15.0, np.linspace(0.0, 0.3, 7))
    assert g.ok
    touch = g.first_touch
    assert touch is not None and [e.status for e in g.events if e.kind == "touch"][0] == "converged"
    before = solve_contact(g.points[0].scene, pressure=touch * (1 - 1e-6))
    after = solve_contact(g.points[0].scene, pressure=touch * (1 + 1e-3))
    assert before.contacts == () and len(after.contacts) >= 1
    assert before.gaps[0] <= 1e-4  # it was about to touch


def test_displacement_path_marks_negative_stiffness():
    t = displacement_path(Scene(segments=3), 0.17, [84.0, 88.0, 89.0, 90.0])
    assert t.ok
    soft = [not p.kkt.dead_load_stable for p in t.points]
    assert soft[0] is False and soft[-1] is True


def test_symbolic_surface_matches_numpy():
    theta = np.array([0.4, -0.2, 1e-9, 0.9])
    sigma = np.array([0.3, 0.7, 0.5, 0.1])
    t, s = ca.SX.sym("t", 4), ca.SX.sym("s", 4)
    joints, inside = symbolic_surface(t, 135.0, 16.0, s)
    f = ca.Function("f", [t, s], [ca.horzcat(*[ca.vertcat(*q) for q in inside]), ca.horzcat(*[ca.vertcat(*q) for q in joints])])
    a, b = (np.asarray(v) for v in f(theta, sigma))
    assert np.allclose(a.T, surface_points(theta, 135.0, 16.0, sigma[:, None])[:, 0], atol=1e-12)
    assert np.allclose(b.T, surface_points(theta, 135.0, 16.0, np.ones((4, 1)))[:, 0], atol=1e-12)


def test_closest_points_are_the_minima_of_a_dense_sample():
    theta = np.array([0.3, 0.5, 0.9])
    c = Cylinder(centre=(60.0, 60.0), radius=10.0)
    sigma, interior, gap = closest_points(theta, 135.0, 0.0, c)
    dense = c.distance(surface_points(theta, 135.0, 0.0, np.tile(np.linspace(0, 1, 20001), (3, 1))))
    for i in range(3):
        if interior[i]:
            assert gap[i] <= dense[i].min() + 1e-12


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: Scene(obstacles=(Cylinder(centre=(60.0, -5.0), radius=3.0),)), "reaches 8 mm into the actuator at rest"),
        (lambda: Cylinder(centre=(60.0, 30.0), radius=-2.0), "cylinder.radius=-2: expected a radius > 0 mm"),
        (lambda: Cylinder(centre=(math.nan, 30.0), radius=2.0), "cylinder.centre[0]=nan: expected a finite number"),
        (lambda: HalfPlane(at=(-1.0, 0.0)), "behind the base"),
        (lambda: HalfPlane(at=(10.0, 0.0), normal_deg=math.inf), "half-plane.normal_deg=inf"),
        (lambda: scene_from_dict({"obstacles": [{"kind": "cylinder", "centre": [60, 30]}, {"kind": "cube"}]}), "[[obstacles]] #2: kind='cube'"),
        (lambda: scene_from_dict({"obstacles": [{"kind": "half-plane", "at": [135, 0], "radius": 3}]}), "unknown key(s) radius"),
        (lambda: Displacement(y=math.nan), "displacement.y=nan"),
        (lambda: Displacement(x=math.inf), "displacement.x=inf: expected a finite number"),
        (lambda: Displacement(), "displacement: no coordinate given: expected x, y or both (mm)"),
        (lambda: solve_contact(Scene(segments=3, pressure=0.17), displacement=Displacement(x=140.0, y=60.0)),
         "displacement=(x=140, y=60): the target is 152.3 mm from the base, farther than the actuator's length L = 135 mm"),
        (lambda: solve_contact(Scene(segments=3, pressure=0.17), displacement=Displacement(y=-136.0)),
         "displacement=(y=-136): the target is 136 mm from the base"),
        (lambda: displacement_path(Scene(segments=3), 0.17, [0.0, 80.0, 140.0]), "displacement=(y=140): the target is 140 mm from the base"),
    ],
)
def test_bad_input_is_one_line(make, message):
    with pytest.raises((SceneError, ObstacleError, ValueError)) as info:
        make()
    text = str(info.value)
    assert message in text and "\n" not in text


def test_a_contact_sliding_across_a_joint_is_located():
    g = grasp(Scene(segments=8), (70.0, 45.0), 15.0, [0.24, 0.25])
    (slide,) = [e for e in g.events if e.kind == "slide"]
    assert slide.status == "converged" and "across joint 6 into segment 7" in slide.where
    scene = g.points[0].scene
    before = solve_contact(scene, pressure=slide.parameter - 1e-4)
    after = solve_contact(scene, pressure=slide.parameter + 1e-4)
    assert [c.where for c in before.contacts] == ["inside segment 6"]
    assert [c.where for c in after.contacts] == ["inside segment 7"]
    assert 0.745 < before.contacts[0].s < 0.75 < after.contacts[0].s < 0.755  # either side of joint 6 (s = 6/8)


def test_a_wall_behind_the_actuator_touches_its_dorsal_surface():
    """A payload pushes the unpressurised actuator back (-y) onto a wall behind it: the outer surface,
    2 r1 off the layer, touches the wall's face."""
    wall = HalfPlane(at=(100.0, -40.0), normal_deg=270.0)  # face y = -40 looking towards +y
    assert wall.resolved_side() == "outer"
    scene = Scene(segments=3, pressure=0.0, payloads=(Payload(3.0, 90.0, 1.0),), obstacles=(wall,))
    r = solve_contact(scene)
    assert r.ok, r.message
    assert r.contacts and all(c.surface == "outer" and c.direction == (0.0, 1.0) for c in r.contacts)
    c = r.contacts[-1]
    assert abs(c.point[1] + 40.0) <= 1e-9
    layer = surface_points(r.theta, 135.0, 0.0, np.array([[c.s * 3 - int(min(c.s * 3, 2.999999))]] * 3))[min(int(c.s * 3), 2), 0]
    assert abs(np.hypot(*(layer - np.array(c.point))) - 16.0) <= 1e-9  # the layer is 2 r1 from the contact point


def test_touch_and_lift_off_are_the_same_pressure_both_ways():
    scene = Scene(segments=3, pressure=0.0, obstacles=(Cylinder(centre=(70.0, 45.0), radius=15.0),))
    up = contact_path(scene, [0.05, 0.15])
    down = contact_path(scene, [0.15, 0.05])
    (touch,) = [e for e in up.events if e.kind == "touch"]
    (lift,) = [e for e in down.events if e.kind == "lift-off"]
    assert touch.status == lift.status == "converged"
    assert abs(touch.parameter - lift.parameter) <= 1e-9  # frictionless: no hysteresis
    assert [e.kind for e in down.events] == ["lift-off"]  # a real lift-off (the force goes to zero) stays one
    just_before = solve_contact(scene, pressure=lift.parameter + 1e-7, warm=down.points[0].state)
    assert just_before.ok and 0.0 < just_before.contacts[0].force < 1e-4


def test_a_contact_branch_that_ends_with_force_left_is_a_contact_lost_not_a_lift_off():
    """The finger's tip on a small cylinder beside the base (esba grasp --at -30,0 --radius 5): the tip
    slides off it with force left and the actuator snaps through it; the last point fails."""
    g = grasp(Scene(segments=3), (-30.0, 0.0), 5.0, [0.28, 0.29, 0.3])
    assert [(e.kind, e.where, e.status) for e in g.events] == [("touch", "tip", "converged"), ("contact lost", "tip", "converged")]
    lost = g.events[1]
    assert lost.bracket == (0.29, 0.3) and abs(lost.parameter - 0.295326) < 1e-6
    assert lost.force_left > 0.4 and lost.describe() == f"contact lost at tip with {lost.force_left:.4g} N left"
    assert g.events[0].force_left is None and lost.to_dict()["force_left_n"] == lost.force_left
    scene = g.points[0].scene
    held = solve_contact(scene, pressure=lost.parameter - 1e-6, warm=g.points[1].state)
    assert held.ok and [c.where for c in held.contacts] == ["tip"] and held.contacts[0].force > 0.4  # clearly positive when lost
    beyond = solve_contact(scene, pressure=lost.parameter + 1e-6, warm=held.state)
    assert not beyond.success
    failed = g.points[-1]
    assert not failed.ok and failed.contacts == () and failed.contact_length() == 0.0
    assert failed.to_dict()["contact_length_within_0.1mm"] == 0.0


def test_ipopt_certifies_the_active_set_result():
    from esba.statics.contact import ContactOptions

    scene = Scene(segments=8, pressure=0.2, obstacles=(Cylinder(centre=(70.0, 45.0), radius=15.0),))
    fast = solve_contact(scene)
    certified = solve_contact(scene, ContactOptions(certify=True))
    assert fast.status == "Newton_Active_Set" and certified.status.startswith("Newton_Active_Set; IPOPT Solve_Succeeded")
    assert np.max(np.abs(fast.theta - certified.theta)) <= 1e-9


def test_the_tester_figure_gives_each_force_ramp_its_own_legend_entry():
    from esba.figures.contact import tester_figure
    from esba.statics.contact.sweeps import force_ramp

    path = displacement_path(Scene(segments=3), 0.17, [40.0, 60.0, 80.0])
    down = force_ramp(Scene(segments=3), 0.17, [2.0, 1.0, 0.0], theta0=path.points[0].theta)
    up = force_ramp(Scene(segments=3), 0.17, [0.0, 1.0, 2.0])
    handles, labels = tester_figure(path, (down, up)).axes[0].get_legend_handles_labels()
    ramps = [(h.get_color(), t) for h, t in zip(handles, labels) if t.startswith("force control")]
    assert len(ramps) == 2 and ramps[0][0] != ramps[1][0]
    assert ramps[0][1].startswith("force control, ramp down 2 to 0 N") and ramps[1][1].startswith("force control, ramp up 0 to 2 N")
    assert np.all(np.isfinite(path.reactions)) and path.reactions.shape == (3, 2)
