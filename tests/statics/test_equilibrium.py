"""Equilibria: Table 2, the closed-form pressure, stationarity and stability, continuation, failures."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from esba.calibration.validation import TABLE2, TOLERANCE_DEG, TOLERANCE_MM, table2
from esba.model.scene import MAIN_JOB, Payload, Scene, SceneError
from esba.paths.continuation import PathOptions
from esba.statics.equilibrium import (
    EquilibriumError,
    SolverOptions,
    SolverOptionsError,
    evaluate,
    pressure_for_angle,
    solve,
    stability_verdict,
)

# Tolerances, in one place
#: stationarity at a solved equilibrium, N mm/rad (Newton-polished: round-off is ~1e-13)
GRAD_TOL = 1e-9
#: agreement of two independent solver routes to the same equilibrium, degrees
SAME_STATE_DEG = 1e-6
#: closed-form pressure vs a numeric root of the solved unloaded angle, relative
PRESSURE_RTOL = 1e-8
#: the unloaded constant-curvature shape, degrees and mm
UNIFORM_DEG, UNIFORM_MM = 1e-8, 1e-8

#: The 90 degree pressure of the Table 1 actuator (MPa), as verified for the derivation (n = 1).
P90 = {"paper": 0.1238739, "printed": 0.13837}


# ---------------------------------------------------------------------------------------------
# Table 2 (docs/validation.md shows the same comparison, written by `esba validate`)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_table2(n):
    (case,) = table2(segments=(n,))
    r = case.result
    assert r.ok, r.message
    ref = TABLE2[n]
    assert np.allclose(r.theta_deg, ref["theta"], atol=TOLERANCE_DEG, rtol=0)
    assert r.total_angle_deg == pytest.approx(ref["total"], abs=TOLERANCE_DEG)
    assert r.tip_mm[0] == pytest.approx(ref["x"], abs=TOLERANCE_MM)
    assert r.tip_mm[1] == pytest.approx(ref["y"], abs=TOLERANCE_MM)
    assert case.passed


def test_table2_brief_numbers():
    """The values verified for the derivation, to 0.01 deg / 0.01 mm, at the 90 degree pressure."""
    expected = {
        1: ([22.14], (131.66, 25.77)),
        2: ([-1.39, 26.26], (133.01, 12.79)),
        3: ([-3.29, 7.17, 21.44], (133.24, 10.22)),
        4: ([-3.30, 2.12, 9.02, 17.64], (133.32, 9.31)),
    }
    for n, (theta, tip) in expected.items():
        r = solve(MAIN_JOB.replace(segments=n))
        assert np.allclose(r.theta_deg, theta, atol=0.006), n
        assert np.allclose(r.tip_mm, tip, atol=0.006), n


# ---------------------------------------------------------------------------------------------
# the closed-form pressure


@pytest.mark.parametrize("variant", ["paper", "printed"])
def test_p90_matches_verified_value(variant):
    p = pressure_for_angle(Scene(segments=1, variant=variant), 90.0)
    assert p == pytest.approx(P90[variant], abs=5e-6 if variant == "printed" else 5e-8)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_p90_same_for_every_n(n):
    """Variant paper: the unloaded state is exact for every n, so is its pressure."""
    assert pressure_for_angle(Scene(segments=n), 90.0) == pytest.approx(pressure_for_angle(Scene(segments=1), 90.0), rel=1e-12)


def test_p90_printed_depends_on_n():
    """Variant printed: Eq. (13) as printed, factor (L + r1 theta_i), is not invariant under subdivision."""
    p = [pressure_for_angle(Scene(segments=n, variant="printed"), 90.0) for n in (1, 2, 3)]
    assert p[0] > p[1] > p[2]


@pytest.mark.parametrize("variant", ["paper", "printed"])
@pytest.mark.parametrize("n, angle", [(1, 90.0), (3, 45.0), (3, 180.0), (4, 259.5)])
def test_closed_form_pressure_vs_numeric_root(n, angle, variant):
    """Closed form against a root of (solved unloaded angle - target) over P, by Brent's method."""
    scene = Scene(segments=n, variant=variant)

    def miss(p: float) -> float:
        r = solve(scene, pressure=p)
        assert r.ok, r.message
        return r.total_angle_deg - angle

    root = brentq(miss, 0.01, 0.6, xtol=1e-12, rtol=1e-12)
    assert pressure_for_angle(scene, angle) == pytest.approx(root, rel=PRESSURE_RTOL)


def test_closed_form_pressure_rejects_negative():
    # a target reached only by suction is refused up front by the scene's own rule for a target
    # angle (issue 30: pressure_for_angle judges the angle as a Scene does)
    with pytest.raises(SceneError, match="target_angle_deg=-10: expected an angle > 0 degrees"):
        pressure_for_angle(Scene(), -10.0)


def test_pressure_for_angle_needs_a_target():
    with pytest.raises(EquilibriumError, match="needs angle_deg"):
        pressure_for_angle(Scene(pressure=0.1))


# ---------------------------------------------------------------------------------------------
# the unloaded shape


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_zero_tip_payload_gives_constant_curvature(n):
    angle = 90.0
    r = solve(Scene(segments=n, target_angle_deg=angle, payloads=(Payload(0.0),)))
    assert r.ok, r.message
    assert np.allclose(r.theta_deg, angle / n, atol=UNIFORM_DEG, rtol=0)
    big_theta = math.radians(angle)
    radius = 135.0 / big_theta
    assert r.tip_mm[0] == pytest.approx(radius * math.sin(big_theta), abs=UNIFORM_MM)
    assert r.tip_mm[1] == pytest.approx(radius * (1 - math.cos(big_theta)), abs=UNIFORM_MM)
    # every centre-line sample lies on the circle of that radius about (0, radius)
    cl = r.centreline
    assert np.allclose(np.hypot(cl[:, 0], cl[:, 1] - radius), radius, atol=1e-8)


@pytest.mark.parametrize("n", [1, 3])
def test_no_payload_model_same_as_zero_payload(n):
    a = solve(Scene(segments=n, pressure=0.15))
    b = solve(Scene(segments=n, pressure=0.15, payloads=(Payload(0.0, 30.0, 0.5),)))
    assert "payload" not in a.scene.effects.names()
    assert np.allclose(a.theta, b.theta, atol=math.radians(SAME_STATE_DEG))


# ---------------------------------------------------------------------------------------------
# payload direction, point of application, n and variant


def _assert_equilibrium(r):
    assert r.ok, r.message
    assert r.gradient_norm < GRAD_TOL
    values = r.parameters
    pv = r.model.param_vector(values)
    assert np.max(np.abs(r.model.gradient(r.theta, pv))) < GRAD_TOL
    assert np.all(np.linalg.eigvalsh(r.model.hessian(r.theta, pv)) > 0)
    assert np.all(r.theta > r.model.lower_bounds(values))


@pytest.mark.parametrize("variant", ["paper", "printed"])
@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("at", [0.3, 0.75, 1.0])
@pytest.mark.parametrize("omega", [0, 45, 90, 135, 180, 225, 270, 315, 360])
def test_equilibrium_any_direction_and_point(omega, at, n, variant):
    r = solve(Scene(segments=n, variant=variant, payloads=(Payload(2.0, float(omega), at),)))
    _assert_equilibrium(r)
    # segments wholly beyond the point of application keep the unloaded angle: no moment reaches them
    first_free = math.ceil(n * at - 1e-12)
    assert np.allclose(r.theta_deg[first_free:], 90.0 / n, atol=1e-7)


@pytest.mark.parametrize("n", [2, 3])
def test_direction_is_periodic(n):
    a = solve(Scene(segments=n, payloads=(Payload(1.5, 30.0),)))
    b = solve(Scene(segments=n, payloads=(Payload(1.5, 390.0),)))
    c = solve(Scene(segments=n, payloads=(Payload(1.5, -330.0),)))
    assert np.allclose(a.theta, b.theta, atol=1e-10) and np.allclose(a.theta, c.theta, atol=1e-10)


def test_horizontal_push_unbends_vertical_pull_bends_less():
    unloaded = 90.0
    push = solve(MAIN_JOB).total_angle_deg
    down = solve(MAIN_JOB.replace(payloads=(Payload(2.0, 0.0),))).total_angle_deg
    assert push < unloaded and down < unloaded
    assert solve(MAIN_JOB.replace(payloads=(Payload(2.0, 270.0),))).total_angle_deg > unloaded


def test_two_payloads_at_one_point_add_up():
    """payload:2 model with (1 N + 0.5 N) at one point == payload model with 1.5 N."""
    two = solve(MAIN_JOB.replace(payloads=(Payload(1.0, 60.0, 0.8), Payload(0.5, 60.0, 0.8))))
    one = solve(MAIN_JOB.replace(payloads=(Payload(1.5, 60.0, 0.8),)))
    _assert_equilibrium(two)
    assert two.scene.effects.payloads == 2
    assert np.allclose(two.theta, one.theta, atol=math.radians(SAME_STATE_DEG))
    assert two.terms["payload1"] + two.terms["payload2"] == pytest.approx(one.terms["payload1"], abs=1e-9)


def test_gravity_is_small_for_35_g():
    """Section 4.1: the paper ignores the 35 g weight; with it the Table 2 angles move by < 0.1 deg."""
    with_g = solve(MAIN_JOB.replace(gravity=True))
    _assert_equilibrium(with_g)
    assert "gravity" in with_g.terms
    assert np.allclose(with_g.theta_deg, solve(MAIN_JOB).theta_deg, atol=0.1)
    # weight alone, hanging straight down at zero pressure, is an equilibrium with theta = 0
    hanging = solve(Scene(pressure=0.0, gravity=True))
    assert np.allclose(hanging.theta, 0.0, atol=1e-10)


def test_fibres_off_bends_further():
    assert solve(Scene(pressure=0.12, fibres=False)).total_angle_deg > solve(Scene(pressure=0.12)).total_angle_deg


# ---------------------------------------------------------------------------------------------
# solver behaviour


def test_result_fields():
    r = solve(MAIN_JOB)
    d = r.to_dict()
    for key in ("theta_deg", "total_angle_deg", "tip_mm", "pressure_mpa", "stable", "status", "effects", "segments", "variant", "solve_time_s"):
        assert key in d
    assert d["effects"] == ["air", "axial", "radial", "fibres", "payload"]
    assert d["stable"] is True and d["status"] == "Solve_Succeeded"
    assert set(r.terms) == {"air", "axial", "radial", "fibres", "payload1"}
    assert sum(r.terms.values()) == pytest.approx(r.energy, abs=1e-10)
    assert r.tip[2] == pytest.approx(r.total_angle)
    assert r.centreline.shape == (3 * 20 + 1, 3)
    assert np.allclose(r.centreline[-1, :2], r.tip_mm, atol=1e-9)
    assert r.check() is r


def test_warm_start_and_no_continuation_agree():
    a = solve(MAIN_JOB)
    b = solve(MAIN_JOB, theta0=a.theta + 0.01)
    c = solve(MAIN_JOB, SolverOptions(continuation=False))
    assert b.steps == 1 and b.iterations < a.iterations
    assert np.allclose(a.theta, b.theta, atol=1e-10) and np.allclose(a.theta, c.theta, atol=1e-10)


def test_given_pressure_ramp_matches_target():
    a = solve(MAIN_JOB)
    b = solve(MAIN_JOB.replace(pressure=a.pressure))
    assert np.allclose(a.theta, b.theta, atol=1e-10)


def test_failure_is_reported_not_answered():
    """A load history that cannot be followed to the end, and an IPOPT that cannot certify, are
    reported, never answered."""
    r = solve(MAIN_JOB, SolverOptions(fast=False, path=PathOptions(max_steps=2)))  # the adaptive trace, cut short
    assert not r.ok and not r.success
    assert r.status == "Continuation_Failed"
    assert "max_steps = 2" in r.message
    with pytest.raises(EquilibriumError, match="ramp"):
        r.check()
    r1 = solve(MAIN_JOB, SolverOptions(max_iter=1), theta0=[0.0, 0.0, 0.0])
    assert not r1.ok and r1.status == "Maximum_Iterations_Exceeded" and "IPOPT did not converge" in r1.message
    r2 = solve(MAIN_JOB, SolverOptions(max_iter=1, continuation=False))
    assert not r2.ok and r2.status == "Maximum_Iterations_Exceeded"


def test_unstable_equilibrium_is_flagged():
    """A straight column under a 20 N push along its axis: theta = 0 is stationary but unstable."""
    column = Scene(pressure=0.0, payloads=(Payload(20.0, 180.0),))
    r = evaluate(column, [0.0, 0.0, 0.0])
    assert r.gradient_norm < GRAD_TOL and r.success
    assert r.stability == "unstable" and not r.ok
    assert "unstable" in r.message
    with pytest.raises(EquilibriumError, match="unstable"):
        r.check()
    # solve() buckles away from it to a stable state
    assert solve(column).ok


def test_steep_load_path_is_not_a_jump():
    """One segment, 20 N at 120 deg: the angle rises by about 100 deg within 6 % of the load, but the
    branch never turns back and stays stable (the smallest eigenvalue stays > 2 N mm/rad^2), so
    nothing snaps: no jump is noted (the old 15-degree heuristic called this a jump)."""
    r = solve(Scene(segments=1, payloads=(Payload(20.0, 120.0),)))
    assert r.ok, r.message
    assert r.jumps == () and r.notes == ()


def test_jump_on_load_path_is_noted():
    """A nearly straight actuator (P = 1e-3 MPa) pushed along its axis with 10 N: its stable branch
    folds back at about 2.9 N and the state snaps sideways; solve() says where and from which state
    to which, and returns the stable state the rest of the ramp reaches."""
    r = solve(Scene(pressure=1e-3, payloads=(Payload(10.0, 180.0),)))
    assert r.ok, r.message
    (jump,) = r.jumps
    assert jump.kind == "fold" and jump.point.status == "converged" and 0.28 < jump.lam < 0.30
    assert jump.point.morse_before == 0 and jump.point.morse_after == 1
    assert r.notes and "jump" in r.notes[0] and "fold" in r.notes[0] and "2.90" in r.notes[0]
    assert jump.distance_mm > 50.0
    assert evaluate(r.scene.replace(payloads=(Payload(10.0 * jump.lam_after, 180.0),)), jump.theta_after, r.pressure).ok


def test_evaluate_rejects_outside_domain():
    with pytest.raises(EquilibriumError, match="outside the model's domain"):
        evaluate(MAIN_JOB, [-1.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "ev, verdict",
    [([1.0, 2.0], "stable"), ([-1.0, 2.0], "unstable"), ([0.0, 2.0], "critical"), ([-1e-12, 2.0], "critical"), ([1e-12, 2.0], "critical")],
)
def test_stability_verdict(ev, verdict):
    assert stability_verdict(ev) == verdict


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"tol": 0}, "tol=0: expected a finite number > 0"),
        ({"tol": 2.0}, "tol=2.0: expected a number > 0 and < 1"),
        ({"max_iter": 0}, "max_iter=0: expected a whole number from 1 to 100000"),
        ({"max_iter": 2.5}, "max_iter=2.5: expected a whole number from 1 to 100000"),
        ({"linear_solver": "ma27"}, "linear_solver='ma27': allowed are mumps, spral"),
        ({"continuation": "yes"}, "continuation='yes': expected True or False"),
        ({"path": {"ds": 0.1}}, "path={'ds': 0.1}: expected a PathOptions"),
        ({"stationarity_tol": -1}, "stationarity_tol=-1: expected a finite number > 0"),
        ({"samples_per_segment": 0}, "samples_per_segment=0: expected a whole number from 1 to 1000"),
    ],
)
def test_solver_options_validation(kwargs, message):
    with pytest.raises(SolverOptionsError) as info:
        SolverOptions(**kwargs)
    assert message in str(info.value)


def test_solver_options_frozen_and_theta0_checked():
    import dataclasses

    with pytest.raises(dataclasses.FrozenInstanceError):
        SolverOptions().tol = 1e-3  # type: ignore[misc]
    with pytest.raises(SolverOptionsError, match="theta0 has shape"):
        solve(MAIN_JOB, theta0=[0.1, 0.2])


def test_spral_agrees():
    a = solve(MAIN_JOB)
    b = solve(MAIN_JOB, SolverOptions(linear_solver="spral"))
    assert np.allclose(a.theta, b.theta, atol=1e-10)


@pytest.mark.slow
@pytest.mark.parametrize("n", [12, 20])
def test_many_segments_converge_toward_the_limit(n):
    """More segments: the total angle and tip settle (Table 2's trend continued)."""
    r = solve(MAIN_JOB.replace(segments=n))
    _assert_equilibrium(r)
    r8 = solve(MAIN_JOB.replace(segments=8))
    assert abs(r.total_angle_deg - r8.total_angle_deg) < 0.3


def test_a_state_the_history_reached_is_certified_without_ipopt_when_its_gradient_and_hessian_show_a_minimiser(monkeypatch):
    """Issue 31: at the end of the load history the exact gradient and Hessian certify a strict local
    minimiser (max |dU/dtheta| <= tol, inside the domain, Hessian positive definite), so the default
    solve calls IPOPT no time (main: once per solve, ~0.2-0.4 ms of its ~1.4 ms). Where they do not
    (a tol below round-off, a theta0 start) and with certify="ipopt", IPOPT certifies as before, and
    both certificates give the same state."""
    from esba.statics import equilibrium as module

    calls = []
    real = module.minimise
    monkeypatch.setattr(module, "minimise", lambda *a, **k: calls.append(1) or real(*a, **k))
    window = Scene(pressure=0.17, payloads=(Payload(2.0, 90.0),))
    for scene in (MAIN_JOB, window, MAIN_JOB.replace(segments=10)):
        direct = solve(scene)
        assert calls == [] and direct.ok and direct.status == "Solve_Succeeded" and direct.iterations > 0
        assert direct.certificate.startswith("Solve_Succeeded from the exact gradient and Hessian at the path's end")
        assert direct.gradient_norm <= SolverOptions().tol and direct.eigenvalues[0] > 0
        ipopt = solve(scene, SolverOptions(certify="ipopt"))
        assert calls == [1] and ipopt.certificate.startswith("IPOPT Solve_Succeeded")
        np.testing.assert_allclose(direct.theta, ipopt.theta, rtol=0, atol=1e-12)
        assert direct.steps == ipopt.steps - 1
        calls.clear()
    strict = solve(MAIN_JOB, SolverOptions(tol=1e-20, stationarity_tol=1e-7))  # below round-off: IPOPT decides
    assert calls == [1] and strict.certificate.startswith("IPOPT")
    calls.clear()
    solve(MAIN_JOB, theta0=[0.1, 0.2, 0.3])
    assert calls == [1]
    with pytest.raises(SolverOptionsError, match="certify='sometimes'"):
        SolverOptions(certify="sometimes")
