"""Hard cases stay numerically stable.

Each returns a finite, stability-flagged equilibrium or a clear error; none gives NaN or a silent
wrong answer. The batch path (:mod:`esba.statics.batch`) is checked against :func:`esba.statics.equilibrium.solve`
on the same scenes. n = 128 and the 10 N load paths in every direction are slow tests.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from esba.model.scene import Actuator, Payload, Scene
from esba.paths.loading import history
from esba.paths.problem import PathProblem
from esba.statics.batch import BatchOptions, solve_scenes
from esba.statics.equilibrium import EquilibriumError, solve
from tests.tolerances import (
    BATCH_THETA_ATOL,
    EQUILIBRIUM_GRAD_ATOL,
    FD_ATOL,
    FD_RTOL,
    FD_STEP,
)

INTERPRETED = BatchOptions(compile="never")
TABLE2 = Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0),))


def _finite_and_flagged(r):
    assert np.all(np.isfinite(r.theta)) and np.all(np.isfinite(r.tip)) and math.isfinite(r.energy)
    assert np.all(np.isfinite(r.eigenvalues))
    assert r.stability in ("stable", "critical", "unstable")
    assert r.ok or r.message, "a result that is not ok must say why"


def _batch_agrees(scenes, results):
    b = solve_scenes(scenes, INTERPRETED)
    for i, r in enumerate(results):
        assert bool(b.ok[i]) == r.ok, (scenes[i].describe(), b.messages[i], r.message)
        if r.ok:
            np.testing.assert_allclose(b.theta[i], r.theta, atol=BATCH_THETA_ATOL)
    return b


def _fd_check(scene, theta):
    """Generated gradient and Hessian against central differences of U and of the gradient."""
    model = scene.model()
    pv = model.param_vector(scene.parameters(solve(scene.unloaded()).pressure if scene.pressure is None else scene.pressure))
    theta = np.asarray(theta, dtype=float)
    g = model.gradient(theta, pv)
    h = model.hessian(theta, pv)
    assert np.all(np.isfinite(g)) and np.all(np.isfinite(h))
    eye = np.eye(len(theta)) * FD_STEP
    g_fd = np.array([(model.energy(theta + e, pv) - model.energy(theta - e, pv)) / (2 * FD_STEP) for e in eye])
    h_fd = np.array([(model.gradient(theta + e, pv) - model.gradient(theta - e, pv)) / (2 * FD_STEP) for e in eye])
    np.testing.assert_allclose(g, g_fd, rtol=FD_RTOL, atol=FD_ATOL)
    np.testing.assert_allclose(h, h_fd, rtol=FD_RTOL, atol=FD_ATOL)
    np.testing.assert_allclose(h, h.T, rtol=0, atol=1e-12 * max(1.0, np.abs(h).max()))


# ---------------------------------------------------------------------------------------------
# the straight actuator: theta = 0, where the POE twist's bending radius L / (n theta) is infinite


@pytest.mark.parametrize("n", [1, 3, 8])
def test_no_pressure_no_payload_is_exactly_straight(n):
    scene = Scene(pressure=0.0, segments=n)
    r = solve(scene)
    assert r.ok and r.stability == "stable"
    np.testing.assert_allclose(r.theta, 0.0, atol=1e-12)  # IPOPT's barrier leaves round-off, ~1e-16
    np.testing.assert_allclose(r.tip, [scene.actuator.L, 0.0, 0.0], atol=1e-10)
    b = _batch_agrees([scene], [r])
    np.testing.assert_array_equal(b.theta[0], np.zeros(n))  # Newton from theta = 0 stays there exactly


@pytest.mark.parametrize("theta", [[0.0, 0.0, 0.0], [1e-12, -1e-12, 0.0], [1e-4, 0.0, -1e-4]])
def test_derivatives_at_and_near_straight(theta):
    """Value, gradient and Hessian are right at theta = 0 (the series branch), not NaN or 1e12."""
    _fd_check(Scene(pressure=0.12, payloads=(Payload(2.0, 45.0, 0.7),)), theta)


def test_tiny_pressure_is_linear_and_finite():
    small, ref = (solve(Scene(pressure=p)) for p in (1e-9, 1e-6))
    for r in (small, ref):
        _finite_and_flagged(r)
        assert r.ok
    # the unloaded response is linear near P = 0: theta(1e-9) = 1e-3 theta(1e-6)
    np.testing.assert_allclose(small.theta, 1e-3 * ref.theta, rtol=1e-5)
    assert 0.0 < small.theta[0] < 1e-8
    loaded = solve(Scene(pressure=1e-9, payloads=(Payload(1e-9, 90.0),)))
    _finite_and_flagged(loaded)
    assert loaded.ok
    _batch_agrees([Scene(pressure=1e-9), Scene(pressure=1e-9, payloads=(Payload(1e-9, 90.0),))], [small, loaded])


def test_distal_segments_stay_exactly_straight():
    """No pressure, a payload at mid-length: the segments beyond it carry no moment."""
    scene = Scene(pressure=0.0, payloads=(Payload(1.0, 90.0, at=0.5),), segments=4)
    r = solve(scene)
    assert r.ok
    assert np.all(r.theta[:2] < -1e-3)
    np.testing.assert_allclose(r.theta[2:], 0.0, atol=1e-12)
    _batch_agrees([scene], [r])


def test_one_straight_segment_between_bent_ones():
    """The horizontal payload at which the middle segment of n = 3 is straight (theta_2 = 0)."""
    f0 = brentq(lambda f: solve(TABLE2.replace(payloads=(Payload(f, 90.0),))).theta[1], 2.0, 6.0, xtol=1e-12)
    scene = TABLE2.replace(payloads=(Payload(f0, 90.0),))
    r = solve(scene)
    _finite_and_flagged(r)
    assert r.ok
    assert abs(r.theta[1]) < 1e-9 and r.theta[0] < 0 < r.theta[2]
    _batch_agrees([scene], [r])
    _fd_check(scene, r.theta)
    _fd_check(scene, [0.3, 0.0, -0.2])


# ---------------------------------------------------------------------------------------------
# negative angles and the edges of the design space


@pytest.mark.parametrize("n", [3, 4, 8])
def test_proximal_segment_bends_back(n):
    """Table 2: the horizontal payload bends the proximal segment backwards (theta_1 < 0)."""
    rs = [solve(TABLE2.replace(segments=n, payloads=(Payload(f, 90.0),))) for f in (2.0, 4.0)]
    for r in rs:
        assert r.ok
    assert rs[0].theta[0] < 0 and rs[1].theta[0] < rs[0].theta[0]
    assert np.all(np.isfinite([r.theta for r in rs]))


EDGES = {
    "r2=0.05": dict(r2=0.05),
    "d=0": dict(d=0.0),
    "r2+d=r1-0.05": dict(r2=3.95, d=4.0),
    "r2=0.05, d=r1-0.1": dict(r2=0.05, d=7.9),
    "r2=r1-0.1, d=0": dict(r2=7.9, d=0.0),
    "rho=0": dict(rho_deg=0.0),
    "rho=40": dict(rho_deg=40.0),
}


@pytest.mark.parametrize("edge", list(EDGES))
def test_edges_of_the_design_space(edge):
    """Each design: a finite, flagged equilibrium at P = 0.12 MPa and at its 90 degree pressure,
    or a clear error (rho = 40 deg: the fibres outweigh the air, no pressure >= 0 bends it to 90)."""
    act = Actuator(**EDGES[edge])
    scenes = [Scene(actuator=act, pressure=0.12, payloads=(Payload(2.0, 90.0),))]
    results = [solve(scenes[0])]
    target = Scene(actuator=act, target_angle_deg=90.0, payloads=(Payload(2.0, 90.0),))
    try:
        results.append(solve(target))
        scenes.append(target)
    except EquilibriumError as exc:
        assert edge == "rho=40" and "negative pressure" in str(exc)
        b = solve_scenes([target], INTERPRETED)
        assert not b.ok[0] and "negative pressure" in b.messages[0]
    for r in results:
        _finite_and_flagged(r)
        assert r.ok, r.message
    _batch_agrees(scenes, results)


# ---------------------------------------------------------------------------------------------
# many segments


def _many_segments(n, record_property):
    scene = TABLE2.replace(segments=n)
    r = solve(scene)
    assert r.ok and r.gradient_norm <= EQUILIBRIUM_GRAD_ATOL
    condition = float(r.eigenvalues[-1] / r.eigenvalues[0])
    record_property(f"hessian_condition_n{n}", condition)
    assert 1.0 <= condition < 10.0  # measured 2.5 for n = 64 ... 256 (docs/accuracy-vs-time.md)
    # the converged tip (Richardson limit from n = 64, 128, 256: 133.4171, 8.1428 mm)
    assert r.tip_mm[0] == pytest.approx(133.417, abs=0.01)
    assert r.tip_mm[1] == pytest.approx(8.143, abs=0.01)
    return scene, r


def test_64_segments(record_property):
    scene, r = _many_segments(64, record_property)
    _batch_agrees([scene], [r])


@pytest.mark.slow
@pytest.mark.ci
def test_128_segments(record_property):
    _many_segments(128, record_property)


# ---------------------------------------------------------------------------------------------
# payload directions and large loads


def test_payload_in_every_direction():
    """2 N at the tip, Omega = 0, 15, ..., 345 deg: all stable, and the tip moves smoothly with
    Omega except once, between 120 and 135 deg, where the actuator is bistable (next test)."""
    omegas = list(range(0, 360, 15))
    scenes = [TABLE2.replace(payloads=(Payload(2.0, float(om)),)) for om in omegas]
    results = [solve(s) for s in scenes]
    for r in results:
        _finite_and_flagged(r)
        assert r.ok, r.message
    _batch_agrees(scenes, results)
    tips = np.array([r.tip[:2] for r in results])
    steps = np.linalg.norm(np.diff(np.vstack([tips, tips[:1]]), axis=0), axis=1)
    big = [omegas[k] for k in np.flatnonzero(steps > 3.0 * np.median(steps))]
    assert big == [120], big


def test_bistable_directions_show_hysteresis():
    """At 2 N and Omega = 120 deg two stable equilibria exist: the one the load path reaches and
    the one reached by turning the payload down from 135 deg. Each turn ends in a snap where the
    smallest Hessian eigenvalue has fallen toward zero; the answer depends on the path, as it
    does for the actuator, and esba reports the load path's (solve's documented path)."""
    at = {om: TABLE2.replace(payloads=(Payload(2.0, float(om)),)) for om in range(135, 117, -1)}
    by_load = solve(at[120])
    theta, eig = solve(at[135]).theta, []
    for om in range(134, 119, -1):  # turn the payload from 135 down to 120 deg, warm-started
        r = solve(at[om], theta0=theta)
        assert r.ok
        theta = r.theta
        eig.append(r.eigenvalues[0])
    by_turning = r
    assert by_load.ok and by_turning.ok
    assert np.linalg.norm(by_load.tip[:2] - by_turning.tip[:2]) > 50.0
    assert eig[-1] < 0.5 * eig[0]  # softening toward the fold at ~119 deg
    on = solve(at[118], theta0=theta)  # one more degree: the turned branch is gone, it snaps back
    assert on.ok and np.linalg.norm(on.tip[:2] - by_load.tip[:2]) < 10.0


def _load_ramp(scene):
    """The scene's payloads raised from 0 to full at its pressure (:func:`esba.paths.loading.history`):
    the ramp and, over its stable pieces, the load factors, angles, smallest Hessian eigenvalues and kinds."""
    unloaded = solve(scene.replace(payloads=tuple(p.scaled(0.0) for p in scene.payloads), gravity=False))
    assert unloaded.ok, unloaded.message
    problem = PathProblem.from_scene(scene, "load", pressure=unloaded.pressure)
    (ramp,) = history(problem, unloaded.theta, 0.0, [1.0])
    factors = np.concatenate([b.lam for b in ramp.pieces])
    theta = np.vstack([b.theta for b in ramp.pieces])
    min_eigenvalue = np.concatenate([b.eigenvalues[:, 0] for b in ramp.pieces])
    kind = np.concatenate([b.kind for b in ramp.pieces])
    return ramp, factors, theta, min_eigenvalue, kind


def test_load_reverses_the_bend_continuously():
    """10 N horizontal on the 90 degree actuator: the bend reverses (total angle < 0) without a jump."""
    scene = TABLE2.replace(payloads=(Payload(10.0, 90.0),))
    ramp, _, theta, min_eigenvalue, _ = _load_ramp(scene)
    assert ramp.reached and not ramp.jumps, ramp.jumps
    total = np.degrees(theta.sum(axis=1))
    assert total[0] == pytest.approx(90.0, abs=1e-6) and total[-1] < -40.0
    assert np.all(np.diff(total) < 0)  # monotonic through zero
    assert np.all(min_eigenvalue > 0)
    np.testing.assert_allclose(solve(scene).theta, theta[-1], atol=BATCH_THETA_ATOL)


def test_snap_through_is_reported():
    """A nearly straight actuator pushed along its axis buckles: the path jumps, and says where."""
    scene = Scene(pressure=1e-3, payloads=(Payload(10.0, 180.0),))
    ramp, factors, theta, min_eigenvalue, _ = _load_ramp(scene)
    assert ramp.reached and ramp.jumps
    (jump,) = ramp.jumps
    assert 0.25 < jump.lam < 0.33  # about 2.9 N
    assert jump.distance_mm > 50.0
    before = min_eigenvalue[factors <= jump.lam]
    assert before[-1] < 0.05 * before[0]  # the stiffness was vanishing: a fold, not a solver hiccup
    r = solve(scene)  # solve() follows the same snap and notes it
    assert r.ok and any("jump" in note for note in r.notes)
    np.testing.assert_allclose(r.theta, theta[-1], atol=BATCH_THETA_ATOL)


@pytest.mark.slow
@pytest.mark.parametrize("omega", [pytest.param(om, marks=pytest.mark.ci) if om % 90 == 0 else om for om in range(0, 360, 15)])
def test_large_load_in_every_direction(omega):
    """10 N from every direction: each path is continuous, or its jumps are reported; never NaN."""
    ramp, _, theta, min_eigenvalue, kind = _load_ramp(TABLE2.replace(payloads=(Payload(10.0, float(omega)),)))
    assert ramp.reached, ramp.message
    held = kind != "fold"  # a fold is where the stable state ends: its critical eigenvalue is 0
    assert np.all(np.isfinite(theta)) and np.all(min_eigenvalue[held] > 0)
    assert np.all(np.abs(min_eigenvalue[~held]) < 1e-6 * np.max(min_eigenvalue))
    for j in ramp.jumps:
        assert j.distance_mm > 2.0 and 0.0 <= j.lam < j.lam_after <= 1.0
