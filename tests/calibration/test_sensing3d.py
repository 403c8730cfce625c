"""The 3-D load estimate (esba estimate in 3-D): synthetic 3-D poses made by the 3-D model, noise with fixed seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from esba.calibration.sensing import Measured, Pose, SensingOptions, estimate_load
from esba.calibration.sensing3d import Pose3D, Sensing3DError, estimate_load3d, force_vector, identifiability3d, predict3d
from esba.calibration.spatial_ls import Measured3D
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import solve

SECTION = {"EI_side": 4e5, "GJ": 1e5}
P = 0.15


def _base(pressure: float = P) -> Scene:
    return Scene(pressure=pressure, payloads=(Payload(0.8, 90.0),))


def _pose(truth: Scene, kinds, noise=None, rng=None) -> Pose3D:
    """The 3-D model's prediction of ``kinds`` ((kind, at, sd)) under ``truth``, with Gaussian noise of the stated sd."""
    q, preds = predict3d(truth, SECTION, truth.pressure, [(k, a) for k, a, _ in kinds])
    measured = []
    for (kind, at, sd), v in zip(kinds, preds):
        v = np.array(v, dtype=float)
        if noise:
            if kind == "rotation":  # the measured frame turned by a random small rotation of sd per axis
                w = rng.normal(0.0, math.radians(sd), 3)
                v = (v.reshape(3, 3) @ Rotation.from_rotvec(w).as_matrix()).ravel()
            else:
                v = v + rng.normal(0.0, sd, v.size)
        measured.append(Measured3D(kind, tuple(v), sd, at))
    return Pose3D(truth.pressure, tuple(measured))


TIP_POSE = [("tip", None, 0.1), ("rotation", None, 0.2)]


@pytest.mark.parametrize("load, kinds, free, starts", [
    ((1.0, 60.0, 20.0, 1.0), TIP_POSE, ("force", "angle", "out"), 6),  # the default starts: one load found
    ((0.6, 150.0, -35.0, 1.0), [("marker", 0.5, 0.1), ("marker", 1.0, 0.1)], ("force", "angle", "out"), 0),
    ((1.4, 20.0, 50.0, 1.0), [("angles", None, 0.05)], ("force", "angle", "out"), 0),
    ((0.9, 100.0, -15.0, 0.7), TIP_POSE, ("force", "angle", "out", "at"), 0),
])
def test_noise_free_estimate_recovers_the_load_to_1e_8(load, kinds, free, starts):
    F, om, be, at = load
    truth = Scene(pressure=P, payloads=(Payload(F, om, at, be),))
    r = estimate_load3d([_pose(truth, kinds)], free, _base(), SECTION, starts=starts)
    assert r.ok and r.unique and r.identifiable, r.summary()
    expect = {"F1": F, "Omega1": om, "Beta1": be, "s1": at}
    for label in r.labels:
        assert abs(r.value(label) - expect[label]) <= 1e-8 * max(1.0, abs(expect[label])), (label, r.value(label))
    # the force vector is the payload's direction in space, F (cos B cos Omega, -cos B sin Omega, sin B)
    assert np.allclose(r.force, force_vector(F, om, be), atol=1e-8)
    assert r.chi2 < 1e-12


def test_noise_free_estimate_recovers_a_tip_moment_from_the_joint_angles():
    from esba.derive.effects3d import Effects3D
    from esba.model.spatial import load_model3d
    from esba.statics.spatial import scene_values3d, solve3d

    truth = Scene(pressure=P, payloads=(Payload(0.7, 70.0, 1.0, 25.0),))
    eff, values = scene_values3d(truth, SECTION)
    model = load_model3d(3, Effects3D(moments=1), "paper")
    assert eff.payloads == 1 and model.effects.moments == 1
    values.update(mx1=20.0, my1=-30.0, mz1=15.0, sm1=1.0)
    eq = solve3d(model, values)
    assert eq.ok
    pose = Pose3D(P, (Measured3D("angles", tuple(np.degrees(eq.q)), 0.05),))
    r = estimate_load3d([pose], ("force", "angle", "out", "moment"), _base(), SECTION, starts=0)
    assert r.ok and r.identifiable, r.summary()
    want = [0.7, 70.0, 25.0, 20.0, -30.0, 15.0]
    assert np.abs(r.estimate - want).max() <= 1e-8 * 30
    # the tip pose alone (6 numbers for 6 unknowns) does not separate the force from the moment:
    # the rule finds the Fisher matrix nearly singular; tip position alone has rank 3 at most
    tip_only = identifiability3d(truth, [("tip", None, 0.1)], ("force", "angle", "out", "moment"), SECTION)
    assert tip_only.rank == 3 and not tip_only.identifiable
    pose6 = identifiability3d(truth, TIP_POSE, ("force", "angle", "out", "moment"), SECTION)
    assert not pose6.identifiable and pose6.words


def test_identifiability_is_computed_from_the_sensitivity():
    truth = Scene(pressure=P, payloads=(Payload(1.0, 60.0, 1.0, 20.0),))
    # tip position: three numbers cannot give four unknowns (magnitude, direction and point)
    a = identifiability3d(truth, [("tip", None, 0.1)], ("force", "angle", "out", "at"), SECTION)
    assert a.rank == 3 and not a.identifiable and a.condition == math.inf
    assert any("do not separate" in w for w in a.words)
    # the tip's position and orientation separate them
    b = identifiability3d(truth, TIP_POSE, ("force", "angle", "out", "at"), SECTION)
    assert b.rank == 4 and b.identifiable and not b.words
    assert b.singular[0] >= b.singular[-1] > 0 and b.condition == pytest.approx(b.singular[0] / b.singular[-1])
    # halving the stated deviations halves the standard errors (first order, the Fisher matrix)
    half = identifiability3d(truth, [("tip", None, 0.05), ("rotation", None, 0.1)], ("force", "angle", "out", "at"), SECTION)
    assert np.allclose(half.std_error, b.std_error / 2, rtol=1e-9)


def _binomial_ok(hits: int, n: int, rate: float) -> bool:
    return stats.binomtest(hits, n, rate).pvalue >= 1e-3


def _coverage(count: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    level = 0.95
    chi2_95 = stats.chi2.ppf(level, 3)
    hits = np.zeros(4, dtype=int)
    for _ in range(count):
        F, om, be = rng.uniform(0.3, 1.5), rng.uniform(0.0, 180.0), rng.uniform(-45.0, 45.0)
        truth = Scene(pressure=P, payloads=(Payload(F, om, 1.0, be),))
        pose = _pose(truth, TIP_POSE, noise=True, rng=rng)
        r = estimate_load3d([pose], ("force", "angle", "out"), Scene(pressure=P, payloads=(Payload(F, om, 1.0, be),)), SECTION, starts=0)
        assert r.status in ("ok", "misfit") and r.identifiable, r.summary()
        hits[:3] += (r.interval[:, 0] <= [F, om, be]) & ([F, om, be] <= r.interval[:, 1])
        # the joint region is stated for the force vector (base frame), where the model is nearly
        # linear in the load; (F, Omega, Beta) are polar coordinates of it, whose joint ellipse is
        # bent by the curvature of the map (each of their intervals covers, their joint ellipse does not)
        d = r.force - force_vector(F, om, be)
        hits[3] += d @ np.linalg.solve(r.force_covariance, d) <= chi2_95
    for h in hits:  # each interval, and the force vector's joint 95 % region
        assert _binomial_ok(int(h), count, level), (hits, count)


def test_noisy_estimate_covers_at_its_stated_rate_fast_subset():
    _coverage(30, seed=3)


@pytest.mark.slow
def test_noisy_estimate_covers_at_its_stated_rate_over_240_random_loads():
    _coverage(240, seed=11)


def _planar_and_3d(truth: Scene, planar_kind, spatial_kind, noise: float, seed: int):
    rng = np.random.default_rng(seed)
    eq = solve(truth)
    assert eq.ok
    if planar_kind == "tip":
        xy = np.asarray(eq.tip_mm) + rng.normal(0.0, noise, 2)
        planar = Measured("tip", tuple(xy), 0.1)
        spatial = Measured3D("tip", (xy[0], xy[1], 0.0), 0.1)
    else:
        th = np.degrees(eq.theta) + rng.normal(0.0, noise, 3)
        planar = Measured("theta", tuple(th), 0.05)
        spatial = Measured3D("angles", (*th, 0, 0, 0, 0, 0, 0), 0.05)
    base = Scene(pressure=P, payloads=(Payload(1.0, 80.0),))  # both start there, and only there
    r2 = estimate_load(Pose(P, (planar,)), ("F1", "Omega1"), base, SensingOptions(tol=1e-14, starts=0, branches=False))
    r3 = estimate_load3d([Pose3D(P, (spatial,))], ("force", "angle", "out"), base, SECTION, starts=0)
    return r2, r3


@pytest.mark.parametrize("kind", ["tip", "theta"])
def test_in_plane_loads_reduce_to_the_planar_estimate_to_1e_10(kind):
    truth = Scene(pressure=P, payloads=(Payload(1.2, 70.0),))
    r2, r3 = _planar_and_3d(truth, kind, kind, 0.0, 1)
    assert r2.ok and r3.ok
    assert abs(r3.value("Beta1")) <= 1e-10
    assert np.abs(r3.estimate[:2] - r2.estimate).max() <= 1e-10 * np.maximum(1.0, np.abs(r2.estimate)).max()
    # the out-of-plane unknown is uncoupled from the in-plane ones at an in-plane state: the same intervals
    assert np.abs(r3.std_error[:2] / r2.std_error - 1).max() <= 1e-10
    assert abs(r3.correlation[0, 2]) <= 1e-10 and abs(r3.correlation[1, 2]) <= 1e-10


def test_noisy_in_plane_segment_angles_give_the_planar_estimate():
    truth = Scene(pressure=P, payloads=(Payload(1.2, 70.0),))
    r2, r3 = _planar_and_3d(truth, "theta", "angles", 0.05, 3)
    assert r2.ok and r3.ok and r3.value("Beta1") == 0.0
    # the planar iteration stops once a step lowers its cost by less than 1e-14 of itself, so it
    # agrees with the 3-D minimum to that resolution: the 3-D cost is not above it, and the
    # estimates differ by far less than their standard errors
    assert r3.chi2 <= r2.chi2 * (1 + 1e-12)
    assert np.abs((r3.estimate[:2] - r2.estimate) / r2.std_error).max() <= 1e-6
    assert np.abs(r3.std_error[:2] / r2.std_error - 1).max() <= 1e-6


def test_bad_measurements_are_refused_in_one_line():
    with pytest.raises(Sensing3DError, match="not a rotation matrix"):
        Measured3D("rotation", (1, 0, 0, 0, 1, 0, 0, 0, 1.01), 0.2)
    near = Measured3D("rotation", (1, 0, 0, 0, 1, 0, 0, 0, 1.0002), 0.2)  # a tracker's 4 decimals: the nearest rotation
    assert np.allclose(np.reshape(near.values, (3, 3)), np.eye(3), atol=1e-15)
    with pytest.raises(Sensing3DError, match="reflection"):
        Measured3D("rotation", (1, 0, 0, 0, 1, 0, 0, 0, -1), 0.2)
    with pytest.raises(Sensing3DError, match="finite"):
        Measured3D("tip", (1.0, math.nan, 0.0), 0.1)
    with pytest.raises(Sensing3DError, match="expected 3 values"):
        Measured3D("tip", (1.0, 2.0), 0.1)
    pose = Pose3D(P, (Measured3D("angles", (0.0,) * 6, 0.1),))
    with pytest.raises(Sensing3DError, match="3n = 9"):
        estimate_load3d([pose], base=_base(), section=SECTION)
    with pytest.raises(Sensing3DError, match="free 'weight'"):
        estimate_load3d([_pose(_base(), TIP_POSE)], ("weight",), _base(), SECTION)
    with pytest.raises(Sensing3DError, match="EI_side"):
        estimate_load3d([_pose(_base(), TIP_POSE)], ("force",), _base(), {"EI_side": -1.0})
