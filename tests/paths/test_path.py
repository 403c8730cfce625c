"""Path following: buckling against a closed form, branch switching, folds located two ways
and from both directions, Morse indices, hysteresis of quasi-static loading, quadratic correctors.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from esba.model.scene import Payload, Scene
from esba.paths.continuation import (
    PathError,
    PathOptions,
    PathProblem,
    bifurcating_branches,
    branches_csv,
    trace,
    write_branches,
)
from esba.paths.loading import follow, history
from esba.statics.equilibrium import SolverOptions, evaluate, solve
from tests.tolerances import EQUILIBRIUM_GRAD_ATOL, LOCATE_RTOL, QUADRATIC_CONSTANT

TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "E": 0.54}


def column_buckling_load(n: int, L=135.0, r1=8.0, r2=3.0, d=4.0, E=0.54) -> float:
    """The tip load (N) at which the straight actuator (P = 0) pushed along its axis buckles.

    Derived here, independently of derive/: at theta = 0 the Hessian is k0 I + F X'' and it turns
    singular at F = k0 / lambda_max(-X'').

    * k0, the elastic stiffness of one segment at theta = 0: Eq. (8) gives
      d2Ua/dtheta_i^2 = n E pi (5 r1^4 - 4 r2^2 (r1 + d)^2 - r2^4) / (4 L); Eq. (13) (the paper
      variant's factor L + n r1 theta_i, equal to L at 0) with Delta r2 = 0 at theta = 0 gives
      d2Ur/dtheta_i^2 = E pi L (r1 + r2) / (n (r1 - r2)) (d Delta r2 / d theta_i)^2, with
      d Delta r2 / d theta_i = n (r1^3 - r2^2 (d + r1)) / (2 r2 L) from Eq. (10).
    * X'', the Hessian of the tip's x at theta = 0: segment i is an arc of length L/n from heading
      phi_{i-1} = theta_1 + ... + theta_{i-1} to phi_{i-1} + theta_i, so its x extent is
      (L/n) int_0^1 cos(phi_{i-1} + t theta_i) dt = (L/n) (1 - (phi_{i-1}^2 + phi_{i-1} theta_i + theta_i^2/3) / 2) + O(theta^4).
    * The payload's energy at Omega = 180 deg is F (x - L) (Eq. 14).
    """
    k_axial = n * E * math.pi * (5 * r1**4 - 4 * r2**2 * (r1 + d) ** 2 - r2**4) / (4 * L)
    dr = n * (r1**3 - r2**2 * (d + r1)) / (2 * r2 * L)
    k_radial = E * math.pi * L * (r1 + r2) / (n * (r1 - r2)) * dr**2
    quad = np.zeros((n, n))
    for i in range(n):
        a = np.zeros(n)
        a[:i] = 1.0
        e = np.zeros(n)
        e[i] = 1.0
        quad += 2 * np.outer(a, a) + np.outer(a, e) + np.outer(e, a) + 2.0 / 3.0 * np.outer(e, e)
    x_hessian = -(L / (2 * n)) * quad
    return (k_axial + k_radial) / float(np.max(np.linalg.eigvalsh(-x_hessian)))


def column(n: int, force: float) -> Scene:
    return Scene(pressure=0.0, payloads=(Payload(force, 180.0),), segments=n)


def assert_equilibria(problem: PathProblem, branch) -> None:
    """Every point of a branch is an equilibrium, with the Morse index of its Hessian."""
    for lam, theta, morse in zip(branch.lam, branch.theta, branch.morse):
        g, h, _ = problem.ghl(theta, lam)
        assert np.max(np.abs(g)) <= EQUILIBRIUM_GRAD_ATOL
        eig = np.linalg.eigvalsh(h)
        assert morse == int(np.sum(eig < -1e-9 * np.max(np.abs(eig))))


# ---------------------------------------------------------------------------------------------
# buckling of the straight actuator


@pytest.mark.parametrize("n", range(1, 9))
def test_column_buckles_at_the_closed_form_load(n):
    f_cr = column_buckling_load(n)
    problem = PathProblem.from_scene(column(n, 0.5 * f_cr), "payload")
    b = trace(problem, np.zeros(n), 0.5 * f_cr, to=1.5 * f_cr)
    assert b.stopped == "bound" and b.lam[-1] == 1.5 * f_cr
    assert np.max(np.abs(b.theta)) < 1e-10  # the straight branch stays straight
    assert b.folds == ()
    (bp,) = b.branch_points
    assert bp.lam == pytest.approx(f_cr, rel=LOCATE_RTOL)
    assert bp.status == "converged" and (bp.morse_before, bp.morse_after) == (0, 1)
    assert abs(bp.eigenvalue) < 1e-8 * float(np.max(np.abs(b.eigenvalues[0])))
    assert np.linalg.norm(bp.eigenvector) == pytest.approx(1.0)
    assert b.kind[bp.index] == "branch point"

    # branch switching: the crossing branch on both sides of theta = 0, each point an equilibrium
    sides = bifurcating_branches(problem, bp, bounds=(0.5 * f_cr, 1.5 * f_cr))
    assert len(sides) == 2
    signs = []
    for side in sides:
        assert len(side) > 5, side.stop_reason
        assert_equilibria(problem, side)
        signs.append(np.sign(float(side.theta[0] @ bp.eigenvector)))
        assert np.max(np.abs(side.theta[-1])) > 0.05  # it bends
        for fold in side.folds:  # located like any other, the Morse index changing by one
            assert fold.status == "converged" and abs(fold.morse_after - fold.morse_before) == 1
            g, _, _ = problem.ghl(fold.theta, fold.lam)
            assert np.max(np.abs(g)) <= EQUILIBRIUM_GRAD_ATOL
    assert any(side.folds for side in sides)  # the side bending away from the chamber (theta > 0) folds back (transcritical)
    assert signs[0] == -signs[1]  # one branch to each side of the straight state
    # the eccentric chamber makes U not even in theta: the two sides differ
    assert not np.allclose(sides[0].lam[:5], sides[1].lam[:5])


def test_transcritical_buckling_one_side_folds():
    """n = 2: bending away from the chamber (theta > 0: the chamber on the convex side) loses load
    (unstable) until a fold at about 2.72 N, where it turns stable; bending towards the chamber carries
    more load and is stable from the start. The branch point is transcritical, and each side is
    labelled by the way it bends."""
    f_cr = column_buckling_load(2)
    problem = PathProblem.from_scene(column(2, 1.0), "payload")
    b = trace(problem, np.zeros(2), 1.0, to=12.0)
    sides = bifurcating_branches(problem, b.branch_points[0], bounds=(1.0, 12.0))
    plus = next(side for side in sides if side.folds)
    minus = next(side for side in sides if side is not plus)
    assert np.sum(plus.theta[1]) > 0 > np.sum(minus.theta[1])  # away from the chamber, and towards it
    assert (plus.label, minus.label) == ("bifurcating away from chamber", "bifurcating towards chamber")
    assert b.branch_points[0].bifurcation == "transcritical"
    (fold,) = plus.folds
    assert 2.70 < fold.lam < 2.75 and (fold.morse_before, fold.morse_after) == (1, 0)
    assert plus.morse[1] == 1 and np.all(plus.lam[1:5] < f_cr)  # subcritical: unstable, less load
    assert np.all(minus.morse == 0) and np.all(minus.lam[1:] > f_cr)  # supercritical: stable


def test_unloading_a_buckled_column_returns_straight_through_the_branch_point():
    """n = 4, 1 -> 6.4 N and back: loading buckles smoothly towards the chamber at the branch point, and
    unloading comes back along that branch to the branch point and goes on straight (stable below it).
    It used to report a snap at the branch point to the far side (0 -> 110 deg) and one back at the
    far side's fold: the step off the branch point onto the straight branch was refused, because that
    branch does not move along the null vector."""
    f_cr = column_buckling_load(4)
    problem = PathProblem.from_scene(column(4, 1.0), "payload")
    start = solve(column(4, 1.0)).theta  # straight to round-off (1e-14 rad), as esba path starts
    up, down = history(problem, start, 1.0, [6.4, 1.0], PathOptions(ds_max=0.1))  # esba path's steps
    assert up.reached and down.reached and up.jumps == () and down.jumps == ()
    assert float(np.sum(up.theta)) < 0.0  # buckled towards the chamber (theta < 0)
    assert [round(bp.lam / f_cr, 9) for bp in down.branch_points] == [1.0]
    assert np.max(np.abs(down.theta)) < 1e-8  # straight again at 1 N


def test_99_percent_stays_straight_101_percent_buckles():
    """Near buckling: n = 4, 3.1733 N along the axis is 99 % of the buckling load."""
    f_cr = column_buckling_load(4)
    assert 3.1733 / f_cr == pytest.approx(0.99, abs=1e-4)
    straight = solve(column(4, 0.99 * f_cr))
    assert straight.ok and np.max(np.abs(straight.theta)) < 1e-9
    assert straight.branch_points == () and straight.jumps == ()
    buckled = solve(column(4, 1.01 * f_cr))
    assert buckled.ok and np.max(np.abs(buckled.theta)) > 1e-3
    (bp,) = buckled.branch_points
    assert bp.kind == "branch point" and bp.lam == pytest.approx(1 / 1.01, rel=LOCATE_RTOL)
    assert any("transcritical branch point" in note for note in buckled.notes)  # its type, computed
    assert buckled.jumps == ()  # it goes on along the stable side, no snap


# ---------------------------------------------------------------------------------------------
# folds


@pytest.fixture(scope="module")
def pressure_path():
    """The Table 1 actuator under a 2 N horizontal tip payload, the pressure from 0 to 0.3 MPa (n = 3)."""
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    start = solve(scene)
    problem = PathProblem.from_scene(scene, "pressure")
    return problem, start, trace(problem, start.theta, 0.0, to=0.3)


def test_bistable_pressure_range_has_two_folds(pressure_path):
    problem, _, b = pressure_path
    assert b.stopped == "bound" and b.lam[-1] == 0.3
    upper, lower = b.folds
    assert upper.lam == pytest.approx(0.1735, abs=1e-3) and lower.lam == pytest.approx(0.1636, abs=1e-3)
    assert (upper.morse_before, upper.morse_after) == (0, 1) and (lower.morse_before, lower.morse_after) == (1, 0)
    assert_equilibria(problem, b)
    # the Morse index changes by exactly one at each fold and nowhere else
    changes = np.flatnonzero(np.diff(b.morse))
    assert len(changes) == 2 and np.all(np.abs(np.diff(b.morse))[changes] == 1)
    assert all("fold" in (b.kind[i], b.kind[i + 1]) for i in changes)  # at a fold (its own index is the lower one)
    # lambda turns back at each: it is extremal there
    i, j = upper.index, lower.index
    assert b.lam[i] >= np.max(b.lam[: j + 1]) and b.lam[j] <= np.min(b.lam[i:])


def test_fold_found_two_ways_and_from_both_ends(pressure_path):
    problem, start, b = pressure_path
    by_bisection = trace(problem, start.theta, 0.0, to=0.3, options=PathOptions(locate="bisection"))
    backwards = trace(problem, b.theta[-1], 0.3, to=0.0)
    assert backwards.stopped == "bound" and backwards.lam[-1] == 0.0
    assert [f.method.split(" ")[0] for f in b.folds] == ["extended", "extended"]
    assert [f.method.split(" ")[0] for f in by_bisection.folds] == ["eigenvalue", "eigenvalue"]
    for k, fold in enumerate(b.folds):
        assert by_bisection.folds[k].lam == pytest.approx(fold.lam, rel=LOCATE_RTOL)
        assert backwards.folds[1 - k].lam == pytest.approx(fold.lam, rel=LOCATE_RTOL)  # met in reverse order
        np.testing.assert_allclose(backwards.folds[1 - k].theta, fold.theta, atol=1e-6)
        # the critical mode is a null vector of the Hessian there
        _, h, _ = problem.ghl(fold.theta, fold.lam)
        assert np.linalg.norm(h @ fold.eigenvector) < 1e-7 * np.linalg.norm(h)
    np.testing.assert_allclose(backwards.theta[-1], start.theta, atol=1e-8)  # back to the start


def test_payload_direction_is_bistable_near_120_degrees():
    """At the 90 degree pressure, 2 N turned from 90 to 150 degrees: two folds around 119-123 deg."""
    scene = Scene(payloads=(Payload(2.0, 90.0),))
    start = solve(scene)
    problem = PathProblem.from_scene(scene, "omega")
    b = trace(problem, start.theta, 90.0, to=150.0)
    assert b.stopped == "bound"
    folds = sorted(f.lam for f in b.folds)
    assert len(folds) == 2 and 117.0 < folds[0] < folds[1] < 125.0
    assert b.unit == "deg"


# ---------------------------------------------------------------------------------------------
# quasi-static loading: hysteresis


def test_loading_up_and_down_jumps_at_the_two_folds(pressure_path):
    problem, start, b = pressure_path
    up, down = history(problem, start.theta, 0.0, [0.3, 0.0])
    assert up.reached and down.reached
    (jump_up,) = up.jumps
    (jump_down,) = down.jumps
    upper, lower = b.folds
    assert jump_up.lam == pytest.approx(upper.lam, rel=LOCATE_RTOL) and jump_up.kind == "fold"
    assert jump_down.lam == pytest.approx(lower.lam, rel=LOCATE_RTOL)
    assert jump_up.distance_mm > 50 and jump_down.distance_mm > 50
    # up lands on the upper branch, down on the lower one
    assert np.sum(jump_up.theta_after) > np.sum(jump_up.theta_before)
    assert np.sum(jump_down.theta_after) < np.sum(jump_down.theta_before)
    np.testing.assert_allclose(down.theta, start.theta, atol=1e-7)  # the loop closes


def test_solve_returns_the_state_its_load_history_reaches(pressure_path):
    """Inside the bistable range (0.1636-0.1735 MPa) two stable states exist. solve() inflates
    first and then loads; raising the pressure under the load reaches the other state."""
    problem, start, b = pressure_path
    p = 0.172
    under_load = follow(problem, start.theta, 0.0, p)  # pressure raised under the 2 N payload
    scene = Scene(pressure=p, payloads=(Payload(2.0, 90.0),))
    r = solve(scene)
    assert r.ok and under_load.reached and not under_load.jumps
    # solve's own history, traced explicitly: inflate unloaded, then raise the payload
    unloaded_scene = scene.replace(payloads=(Payload(0.0, 90.0),))
    inflate = follow(PathProblem.from_scene(unloaded_scene, "pressure"), np.zeros(3), 0.0, p)
    load = follow(PathProblem.from_scene(scene, "load"), inflate.theta, 0.0, 1.0)
    np.testing.assert_allclose(r.theta, load.theta, atol=1e-8)
    assert abs(r.total_angle_deg - math.degrees(np.sum(under_load.theta))) > 100.0
    assert evaluate(scene, under_load.theta).ok  # the other state is stable too


@pytest.mark.parametrize("below", [True, False])
def test_solve_just_short_of_a_fold_does_not_jump(below):
    """A slightly inflated actuator pushed along its axis folds at 2.90414 N. A ramp whose last step
    goes round the fold and back (its ends both below the target) must still stop at the target on
    the stable side: 0.02 % short of the fold no jump, 0.01 % past it the snap."""
    fold = 2.904143590
    force = fold * (1 - 2e-4) if below else fold * (1 + 1e-4)
    r = solve(Scene(pressure=1e-3, payloads=(Payload(force, 180.0),)))
    assert r.ok
    if below:
        assert not r.jumps and r.total_angle_deg < 9.0
    else:
        (jump,) = r.jumps
        assert jump.lam * force == pytest.approx(fold, rel=1e-8) and r.total_angle_deg > 90.0


# ---------------------------------------------------------------------------------------------
# many n, the corrector


@pytest.mark.parametrize("n", [1, 3, 8, 32, pytest.param(64, marks=[pytest.mark.slow, pytest.mark.ci])])
def test_paths_for_many_segments_converge_quadratically(n):
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),), segments=n)
    start = solve(scene)
    problem = PathProblem.from_scene(scene, "pressure")
    b = trace(problem, start.theta, 0.0, to=0.3)
    assert b.stopped == "bound" and b.lam[-1] == 0.3
    assert len(b.folds) == 2 and all(f.status == "converged" for f in b.folds)
    checked = 0
    for res in b.residuals[1:]:
        for r0, r1 in zip(res, res[1:]):
            if r1 > 1e-11 and r0 < 1.0:  # above round-off, inside the region of quadratic convergence
                assert r1 <= QUADRATIC_CONSTANT * r0**2, res
                checked += 1
    assert checked > 10


def test_branch_files_and_json_are_clean(tmp_path, pressure_path):
    _, _, b = pressure_path
    d = b.to_dict()
    text = json.dumps(d, allow_nan=False)
    assert json.loads(text)["special_points"][0]["label"] == "LP"
    write_branches([b], tmp_path / "b.json", {"scene": "test"})
    assert json.loads((tmp_path / "b.json").read_text())["branches"][0]["points"] == len(b)
    csv_text = branches_csv([b])
    assert csv_text.count("\n") == len(b) + 1 and "fold" in csv_text
    with pytest.raises(PathError, match=r"\.csv or \.json"):
        write_branches([b], tmp_path / "b.txt")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"ds": 0.0}, "ds=0.0: expected a finite number > 0"),
        ({"ds": 1.0}, "expected 0 < ds_min <= ds <= ds_max"),
        ({"locate": "newton"}, "locate='newton': allowed are extended, bisection"),
        ({"max_steps": 0}, "max_steps=0: expected a whole number >= 1"),
        ({"target_iterations": 20}, "expected fewer than max_iterations"),
        ({"max_turn_deg": 200.0}, "max_turn_deg=200.0"),
    ],
)
def test_path_options_are_validated(kwargs, message):
    with pytest.raises(PathError, match=message.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        PathOptions(**kwargs)


@pytest.mark.parametrize(
    "parameter, message",
    [
        ("pressur", "parameter='pressur': allowed are"),
        ("payload2", "the scene has 1 payload"),
        ("M", "only acts with gravity"),
        ("r22", "allowed are"),
    ],
)
def test_bad_parameters_name_what_is_allowed(parameter, message):
    with pytest.raises(PathError, match=message):
        PathProblem.from_scene(Scene(payloads=(Payload(1.0),)), parameter)


def test_design_parameter_path_stops_at_the_design_space_edge():
    """r2 grows until the chamber wall vanishes (r2 + d = r1): a target beyond that edge is refused
    with the range, and a trace to the edge stops just inside it."""
    scene = Scene(pressure=0.05)
    start = solve(scene)
    problem = PathProblem.from_scene(scene, "r2")
    with pytest.raises(PathError, match=r"to=10: outside the range of r2, 1e-06 to 4 mm"):
        trace(problem, start.theta, 3.0, to=10.0)
    edge = problem.domain[1]
    assert 4.0 - 1e-5 < edge < 4.0
    b = trace(problem, start.theta, 3.0, to=edge)
    assert b.stopped == "bound" and b.lam[-1] == edge
    assert np.all(np.diff(b.total_angle_deg) > 0)


# ---------------------------------------------------------------------------------------------
# stopping rules and the other parameters


@pytest.fixture(scope="module")
def direction_start():
    scene = Scene(payloads=(Payload(2.0, 90.0),))
    return PathProblem.from_scene(scene, "omega"), solve(scene)


def test_a_full_turn_of_the_payload_returns_to_the_start(direction_start):
    problem, start = direction_start
    b = trace(problem, start.theta, 90.0, bounds=(-1000.0, 1000.0))
    assert b.stopped == "loop" and "returned to the start" in b.stop_reason
    assert b.lam[-1] == pytest.approx(450.0, abs=1.0)  # one turn of the direction later
    np.testing.assert_allclose(b.theta[-1], start.theta, atol=0.02)
    assert len(b.folds) == 2 and b.unit == "deg"


def test_total_angle_and_user_events_stop_exactly(direction_start):
    problem, start = direction_start
    b = trace(problem, start.theta, 90.0, to=150.0, options=PathOptions(stop_total_angle_deg=100.0))
    assert b.stopped == "event" and "total angle of 100 deg" in b.stop_reason
    assert b.total_angle_deg[-1] == pytest.approx(100.0, abs=1e-9)
    assert b.special[-1].kind == "event" and b.folds  # the fold came first, on the way up to 100 deg
    b = trace(problem, start.theta, 90.0, to=150.0, event=lambda lam, theta: problem.tip(theta, lam)[1] - 60.0)
    assert b.stopped == "event" and "user event" in b.stop_reason
    assert b.tip[-1, 1] == pytest.approx(60.0, abs=1e-9)


@pytest.mark.parametrize("parameter, to", [("at", 0.3), ("E", 1.0), ("rho", 30.0), ("d", 0.0), ("L", 100.0), ("r1", 10.0), ("payload", 0.0)])
def test_every_kind_of_parameter_can_be_followed(direction_start, parameter, to):
    _, start = direction_start
    problem = PathProblem.from_scene(start.scene, parameter, pressure=start.pressure)
    b = trace(problem, start.theta, problem.lam0, to=to)
    assert b.stopped == "bound" and b.lam[-1] == to
    assert_equilibria(problem, b)
    end = solve(problem.scene_at(to), pressure=start.pressure, theta0=b.theta[-1])  # IPOPT agrees at the end
    np.testing.assert_allclose(end.theta, b.theta[-1], atol=1e-7)


# ---------------------------------------------------------------------------------------------
# found in review: near the cusp, empty branches, hostile input, the start on a range's end


def test_two_folds_close_to_the_cusp_are_told_apart():
    """At 1.65 N the bistable range is 17 Pa wide: the default step is far larger, yet both folds are
    found once each, in order, and where a fine trace puts them."""
    scene = Scene(pressure=0.0, payloads=(Payload(1.65, 90.0),))
    start = solve(scene)
    problem = PathProblem.from_scene(scene, "pressure")
    coarse = trace(problem, start.theta, 0.0, to=0.4)
    fine = trace(problem, start.theta, 0.0, to=0.4, options=PathOptions(ds_max=0.01))
    assert len(coarse.folds) == 2 and len(fine.folds) == 2
    for a, b in zip(coarse.folds, fine.folds):
        assert a.lam == pytest.approx(b.lam, rel=LOCATE_RTOL) and a.status == "converged"
    assert coarse.folds[0].lam > coarse.folds[1].lam and abs(coarse.folds[0].total_angle_deg - coarse.folds[1].total_angle_deg) > 5.0
    assert np.all(np.diff(coarse.arclength) >= 0)


def test_an_empty_branch_still_writes(tmp_path):
    scene = Scene(pressure=0.1)
    problem = PathProblem.from_scene(scene, "pressure")
    b = trace(problem, [5.0, -5.0, 5.0], 0.1, to=0.2)  # far outside the domain: no equilibrium there
    assert len(b) == 0 and b.stopped == "start"
    assert json.loads(json.dumps(b.to_dict(), allow_nan=False))["lambda_range"] is None
    assert branches_csv([b]).startswith("branch,point,kind")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"to": 1e300}, "more than 10000"),
        ({"to": -0.3}, "to=-0.3: outside the range of pressure, 0 to inf MPa"),
        ({"bounds": (0.1,)}, r"bounds=\(0.1,\): expected \(low, high\)"),
        ({"to": 0.3, "tangent": [1.0, 0.0]}, r"tangent has shape \(2,\): expected 4 finite numbers"),
        ({"to": 0.3, "tangent": [0.0, 0.0, 0.0, 0.0]}, "tangent: expected a nonzero"),
        ({"to": 0.3, "milestones": ["x"]}, "milestones='x': expected a finite number"),
        ({"to": 0.3, "milestones": [float("nan")]}, "milestones=nan: expected a finite number"),
        ({"to": 0.3, "direction": 0.0}, "direction=0: expected"),
        ({"to": 0.3, "direction": float("nan")}, "direction=nan: expected a finite number"),
        ({"to": 0.3, "event": "x"}, "event='x': expected a function"),
    ],
)
def test_trace_refuses_bad_input(kwargs, message):
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    problem = PathProblem.from_scene(scene, "pressure")
    with pytest.raises(PathError, match=message):
        trace(problem, np.zeros(3), 0.0, **kwargs)
    with pytest.raises(PathError, match="to='x': expected a finite number"):
        follow(problem, np.zeros(3), 0.0, "x")


def test_a_trace_from_an_end_of_its_interval_heading_out_stops_at_once():
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    problem = PathProblem.from_scene(scene, "pressure")
    b = trace(problem, np.zeros(3), 0.0, bounds=(0.0, 0.3), direction=-1.0)
    assert b.stopped == "bound" and len(b) == 1 and "leaves the interval" in b.stop_reason


def test_where_a_snap_lands_does_not_depend_on_how_far_the_ramp_goes(pressure_path):
    problem, start, _ = pressure_path
    near = follow(problem, start.theta, 0.0, 0.3)
    far = follow(problem, start.theta, 0.0, 100.0)
    assert far.jumps[0].lam == pytest.approx(near.jumps[0].lam, rel=LOCATE_RTOL)
    np.testing.assert_allclose(far.jumps[0].theta_after, near.jumps[0].theta_after, atol=1e-5)


def test_no_branch_point_is_invented_where_a_load_ramp_passes_near_the_cusp():
    """Inflated to 0.1684-0.1690 MPa and then loaded to 2 N, the load ramp passes close to the cusp
    of the bistable range (1.645 N). A long step used to land on the unstable middle branch and be
    reported as a branch point and a buckling; now every such ramp is one stable branch, and which
    state it reaches changes once, from the lower to the upper, as the pressure rises."""
    pressures = np.linspace(0.1684, 0.1690, 7)
    angles = []
    for p in pressures:
        scene = Scene(pressure=float(p), payloads=(Payload(2.0, 90.0),))
        fast, reference = solve(scene), solve(scene, SolverOptions(fast=False))
        assert fast.ok and reference.ok and fast.branch_points == () and reference.branch_points == () and reference.jumps == ()
        np.testing.assert_allclose(fast.theta, reference.theta, atol=1e-8)
        angles.append(fast.total_angle_deg)
    upper = np.array(angles) > 150.0
    assert upper[-1] and not upper[0] and np.all(np.diff(upper.astype(int)) >= 0)
