"""The 3-D fit (esba fit with 3-D poses): EI_side and GJ from synthetic 3-D poses under known loads."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from esba.calibration.fit3d import Fit3DError, experiment_information, fit_section
from esba.calibration.sensing3d import Pose3D, predict3d
from esba.calibration.spatial_ls import Measured3D
from esba.model.scene import Payload, Scene

TRUTH = {"EI_side": 3e4, "GJ": 1.5e4}
START = {"EI_side": 1e4, "GJ": 5e4}
#: pressure (MPa), Omega (deg), Beta (deg): a straight and a bent actuator under loads out of the plane
EXPERIMENTS = ((0.0, 90.0, 90.0), (0.1, 90.0, 90.0), (0.15, 90.0, 45.0), (0.15, 0.0, -60.0))


def _rows(rng=None, force=0.3):
    rows = []
    for P, om, be in EXPERIMENTS:
        scene = Scene(pressure=P, payloads=(Payload(force, om, 1.0, be),))
        _, (tip, rot) = predict3d(scene, TRUTH, P, [("tip", None), ("rotation", None)])
        if rng is not None:
            tip = tip + rng.normal(0.0, 0.1, 3)
            rot = (rot.reshape(3, 3) @ Rotation.from_rotvec(rng.normal(0.0, math.radians(0.2), 3)).as_matrix()).ravel()
        pose = Pose3D(P, (Measured3D("tip", tuple(tip), 0.1), Measured3D("rotation", tuple(rot), 0.2)))
        rows.append((pose, (force, om, be, 1.0)))
    return rows


def test_noise_free_3d_poses_give_the_stiffnesses_back():
    r = fit_section(_rows(), Scene(), start=START)
    assert r.ok and r.identifiable, r.summary()
    assert np.abs(r.estimate / [TRUTH["EI_side"], TRUTH["GJ"]] - 1).max() <= 1e-8
    assert r.chi2 < 1e-12 and r.dof == 4 * 6 - 2


def _coverage(count: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    hits = np.zeros(2, dtype=int)
    for _ in range(count):
        r = fit_section(_rows(rng), Scene(), start=TRUTH)
        assert r.status in ("ok", "misfit") and r.identifiable
        truth = np.array([TRUTH["EI_side"], TRUTH["GJ"]])
        hits += (r.interval[:, 0] <= truth) & (truth <= r.interval[:, 1])
    for h in hits:
        assert stats.binomtest(int(h), count, 0.95).pvalue >= 1e-3, (hits, count)


def test_noisy_intervals_cover_fast_subset():
    _coverage(8, seed=5)


@pytest.mark.slow
def test_noisy_intervals_cover_over_200_data_sets():
    _coverage(200, seed=8)


def test_which_experiments_determine_the_stiffnesses_is_computed():
    base = Scene()
    tip_pose = [("tip", None, 0.1), ("rotation", None, 0.2)]
    # a load in the bending plane keeps the actuator in it: neither stiffness acts
    in_plane = experiment_information(base, TRUTH, 0.15, (0.3, 90.0, 0.0, 1.0), tip_pose)
    assert in_plane.rank == 0 and np.all(in_plane.fisher == 0.0)
    # the straight actuator under a sideways tip load bends sideways and does not twist: EI_side only
    straight = experiment_information(base, TRUTH, 0.0, (0.3, 90.0, 90.0, 1.0), tip_pose)
    assert straight.rank == 1 and straight.fisher[1, 1] <= 1e-20 * straight.fisher[0, 0]
    # bent, the same load twists it too: both
    bent = experiment_information(base, TRUTH, 0.15, (0.3, 90.0, 90.0, 1.0), tip_pose)
    assert bent.rank == 2 and all(se is not None and se < 0.1 for se in bent.relative_se)
    # a fit to in-plane rows alone says it cannot determine them
    rows = []
    for P in (0.1, 0.15):
        scene = Scene(pressure=P, payloads=(Payload(0.3, 90.0),))
        _, (tip,) = predict3d(scene, TRUTH, P, [("tip", None)])
        rows.append((Pose3D(P, (Measured3D("tip", tuple(tip), 0.1),)), (0.3, 90.0, 0.0, 1.0)))
    r = fit_section(rows, base, start=TRUTH)
    assert not r.identifiable and any("do not depend on" in w for w in r.warnings)


def test_bad_fit_input_is_refused():
    with pytest.raises(Fit3DError, match="free 'E'"):
        fit_section(_rows()[:1], Scene(), free=("E",))
    with pytest.raises(Fit3DError, match="rows"):
        fit_section([], Scene())
    with pytest.raises(Fit3DError, match="GJ"):
        fit_section(_rows()[:1], Scene(), start={"GJ": math.nan})
