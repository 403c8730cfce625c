"""The exported equilibrium against Python's solve(): the same state to 1e-9 rad, the same status
where the load path snaps; and the model's functions, Newton and the stiffness against Python."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.analysis.stiffness import tangent_stiffness
from esba.export.binding import loads_of, params_of
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import SolverOptions, evaluate, solve
from tests.tolerances import EXPORT_FLOAT_THETA_ATOL, EXPORT_THETA_ATOL, KERNEL_ATOL, KERNEL_RTOL

from .conftest import TABLE1, random_equilibria


def _compare(lib, n: int, scenes, atol: float) -> dict:
    """Solve every scene in C and in Python; return the counts and every disagreement."""
    counts = {"ok": 0, "snapped": 0, "both_failed": 0, "python_failed_c_verified": 0, "fast_path_missed_snap": 0}
    problems = []
    for p, f, a, s in scenes:
        scene = Scene(pressure=p, payloads=(Payload(f, a, s),), segments=n)
        py = solve(scene)
        c = lib.equilibrium(params_of(scene.parameters(p)), loads_of(p, [(f, math.radians(a), s)]))
        assert all(math.isfinite(v) for v in c.values()), (p, f, a, s, c.status_name)
        py_snapped = bool(py.jumps)
        if py.ok and c.status_name == "snapped" and not py_snapped:
            # solve()'s compiled fast ramp (esba.solvers.newton) can step over a fold whose jump its
            # contraction test does not see; the path trace that locates every fold is the arbiter
            if solve(scene, SolverOptions(fast=False)).jumps:
                py_snapped = True
                counts["fast_path_missed_snap"] += 1
        if not py.ok:
            if c.status_name in ("ok", "snapped"):
                # Python's path found a fold but no state to land in after it (its kick must land farther
                # than the kick): the C's answer must then be a stable equilibrium of the scene on its own
                check = evaluate(scene, c.theta)
                if not (check.ok and check.stability == "stable" and "no stable state was found after it" in py.message):
                    problems.append(((p, f, a, s), f"Python failed ({py.message}) and C says {c.status_name}: {check.message}"))
                counts["python_failed_c_verified"] += 1
            else:
                counts["both_failed"] += 1
            continue
        want = "snapped" if py_snapped else "ok"
        gap = float(np.max(np.abs(c.theta - py.theta)))
        if c.status_name != want:
            problems.append(((p, f, a, s), f"C {c.status_name}, Python {want}; max |d theta| = {gap:.3g} rad"))
        elif gap > atol:
            problems.append(((p, f, a, s), f"both {want}; max |d theta| = {gap:.3g} rad > {atol:g}"))
        counts[want] += 1
    return {"counts": counts, "problems": problems}


@pytest.mark.parametrize(
    "n, count, seed",
    [
        pytest.param(3, 40, 11, id="n3-40"),
        pytest.param(8, 10, 12, id="n8-10"),
        pytest.param(3, 200, 1, id="n3-200", marks=[pytest.mark.slow, pytest.mark.ci]),
        pytest.param(8, 50, 2, id="n8-50", marks=[pytest.mark.slow, pytest.mark.ci]),
    ],
)
def test_equilibria_match_solve(exports, n, count, seed):
    _, lib = exports(n)
    got = _compare(lib, n, random_equilibria(count, seed), EXPORT_THETA_ATOL)
    assert not got["problems"], got["problems"][:5]
    counts = got["counts"]
    assert counts["ok"] + counts["snapped"] + counts["both_failed"] + counts["python_failed_c_verified"] == count
    assert counts["snapped"] >= count // 20, counts  # the scenes do exercise the folds
    assert counts["both_failed"] + counts["python_failed_c_verified"] <= count // 50, counts


def test_float_export_matches_solve_to_single_precision(exports):
    """Single precision: the same states to float's accuracy; the same statuses but where a scene is
    so close to a fold that float's round-off cannot tell where the branch ends (at most 1 in 20)."""
    _, lib = exports(3, "float")
    got = _compare(lib, 3, random_equilibria(45, 21), EXPORT_FLOAT_THETA_ATOL)
    far = [msg for _, msg in got["problems"] if msg.startswith("both")]
    assert not far, far
    assert len(got["problems"]) <= 45 // 20, got["problems"]


def test_a_known_snap_is_reported_with_where_it_happened(exports):
    """P = 0.005 MPa, a 5 N push up the axis near the tip: Python's path jumps at a fold."""
    _, lib = exports(3)
    scene = Scene(pressure=0.005, payloads=(Payload(5.0, 180.0, 0.9),))
    py = solve(scene)
    assert py.ok and len(py.jumps) == 1
    c = lib.equilibrium(params_of(scene.parameters(0.005)), loads_of(0.005, [(5.0, math.pi, 0.9)]))
    assert c.status_name == "snapped" and c.snaps == 1 and c.snap_ramp == 1
    jump = py.jumps[0]
    assert c.snap_at == pytest.approx(jump.lam, abs=1e-6)  # the fold's load factor
    assert math.degrees(c.snap_from) == pytest.approx(math.degrees(float(np.sum(jump.theta_before))), abs=1e-2)
    assert math.degrees(c.snap_to) == pytest.approx(math.degrees(float(np.sum(jump.theta_after))), abs=0.5)  # landed a hair later
    assert np.max(np.abs(c.theta - py.theta)) < EXPORT_THETA_ATOL


def test_warm_start_from_a_state_follows_the_loads(exports):
    """From the main job's equilibrium, the loads moved to another scene's: that scene's answer."""
    _, lib = exports(3)
    params = params_of(Scene().parameters(0.0))
    start = loads_of(0.12, [(2.0, math.pi / 2, 1.0)])
    first = lib.equilibrium(params, start)
    target = Scene(pressure=0.15, payloads=(Payload(1.0, 60.0, 0.8),))
    c = lib.equilibrium(params, loads_of(0.15, [(1.0, math.radians(60.0), 0.8)]), start=(first.theta, start))
    py = solve(target)
    assert c.status_name == "ok" and c.snap_ramp == -1
    assert np.max(np.abs(c.theta - py.theta)) < EXPORT_THETA_ATOL
    assert c.iterations < first.iterations  # a warm start: fewer Newton iterations than from straight


def test_newton_finds_an_unstable_equilibrium_and_says_so(exports):
    """The straight actuator under a 6 N push along its axis (past buckling): theta = 0 is an
    equilibrium and a saddle."""
    _, lib = exports(3)
    scene = Scene(pressure=0.0, payloads=(Payload(6.0, 180.0),))
    c = lib.newton(params_of(scene.parameters(0.0)), loads_of(0.0, [(6.0, math.pi, 1.0)]), [1e-3, -1e-3, 1e-3])
    assert c.status_name == "unstable" and c.min_pivot < 0
    assert np.max(np.abs(c.theta)) < 1e-12



@pytest.mark.parametrize("force", [4.0, 6.0, 10.0])
def test_a_straight_actuator_buckles_without_a_jump(exports, force):
    """P = 0 and a push straight up the axis: the straight state loses stability at a branch point and
    the load history goes on along the stable bent branch (solve()'s branch_points), not a snap."""
    _, lib = exports(3)
    scene = Scene(pressure=0.0, payloads=(Payload(force, 180.0),))
    py = solve(scene)
    assert py.ok and len(py.branch_points) == 1 and not py.jumps
    c = lib.equilibrium(params_of(scene.parameters(0.0)), loads_of(0.0, [(force, math.pi, 1.0)]))
    assert c.status_name == "ok" and c.snaps == 0
    assert np.max(np.abs(c.theta - py.theta)) < EXPORT_THETA_ATOL


def test_model_functions_match_the_generated_model(exports):
    _, lib = exports(3)
    scene = Scene(pressure=0.12, payloads=(Payload(2.0, 75.0, 0.7),))
    values = scene.parameters(0.12)
    model = scene.model()
    pv = model.param_vector(values)
    loads = loads_of(0.12, [(2.0, math.radians(75.0), 0.7)])
    rng = np.random.default_rng(3)
    for _ in range(5):
        theta = rng.uniform(-0.2, 0.8, 3)
        status, u, terms = lib.energy(params_of(values), loads, theta)
        assert status == 0
        assert u == pytest.approx(model.energy(theta, pv), rel=KERNEL_RTOL, abs=KERNEL_ATOL)
        assert np.allclose(terms[: len(model.terms)], list(model.energy_terms(theta, pv).values()), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
        status, g = lib.gradient(params_of(values), loads, theta)
        assert status == 0 and np.allclose(g, model.gradient(theta, pv), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
        status, h = lib.hessian(params_of(values), loads, theta)
        assert status == 0 and np.allclose(h, model.hessian(theta, pv), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
        status, tip, points = lib.tip(params_of(values), theta)
        assert status == 0 and np.allclose(tip, model.tip(theta, 135.0), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
        assert np.allclose(points, model.points(theta, 135.0), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)


@pytest.mark.parametrize("n", [3, 8])
def test_tangent_stiffness_matches_python(exports, n):
    _, lib = exports(n)
    for p, f, a in ((0.12, 2.0, 90.0), (0.2, 0.5, 30.0)):
        scene = Scene(pressure=p, payloads=(Payload(f, a),), segments=n)
        r = solve(scene)
        py = tangent_stiffness(r)
        c = lib.stiffness(params_of(scene.parameters(p)), loads_of(p, [(f, math.radians(a), 1.0)]), r.theta)
        assert c.status == 0 and c.min_pivot > 0
        assert np.allclose(c.compliance, py.compliance, rtol=1e-9, atol=0)
        assert np.allclose(c.stiffness, py.matrix, rtol=1e-9, atol=0)
        assert c.horizontal == pytest.approx(py.along(90.0), rel=1e-9)
        assert c.vertical == pytest.approx(py.along(0.0), rel=1e-9)


def test_one_segment_and_other_effect_sets(exports):
    """n = 1 (the compliance is singular: K is zeros), two payloads with gravity, no fibres."""
    _, lib = exports(1)
    c = lib.equilibrium(TABLE1, loads_of(0.12, [(0.5, math.pi / 2, 1.0)]))
    py = solve(Scene(pressure=0.12, payloads=(Payload(0.5),), segments=1))
    assert c.status_name == "ok" and abs(c.theta[0] - py.theta[0]) < EXPORT_THETA_ATOL
    k = lib.stiffness(TABLE1, loads_of(0.12, [(0.5, math.pi / 2, 1.0)]), c.theta)
    assert k.status == 0 and np.all(k.stiffness == 0) and k.horizontal > 0
    _, lib2 = exports(2, effects="air,axial,radial,payload:2,gravity")
    loads = loads_of(0.1, [(1.0, math.pi / 2, 1.0), (0.5, 0.0, 0.5)], g=9.81)
    c = lib2.equilibrium(TABLE1, loads)
    py = solve(Scene(pressure=0.1, payloads=(Payload(1.0, 90.0, 1.0), Payload(0.5, 0.0, 0.5)), gravity=True, fibres=False, segments=2))
    assert c.status_name == "ok" and np.max(np.abs(c.theta - py.theta)) < EXPORT_THETA_ATOL
