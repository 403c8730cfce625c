"""Stiffness (secant as in Section 4.4.3, tangent from the Hessian) and pressure inverse problems."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from esba.analysis.stiffness import (
    PAPER_FORCES,
    pressure_for_target,
    secant_stiffness,
    tangent_stiffness,
    tip_jacobian,
)
from esba.model.scene import MAIN_JOB, Payload, Scene, SceneError
from esba.statics.equilibrium import (
    EquilibriumError,
    SolverOptions,
    pressure_for_angle,
    solve,
)

# Tolerances, in one place
#: secant at a tiny force vs the tangent (the secant's error is O(F)), relative
SECANT_LIMIT_RTOL = 2e-3
#: finite-difference checks of derivatives, relative
FD_RTOL = 1e-5
#: an inverse problem's answer reproduced by a forward solve: degrees, mm
TARGET_DEG, TARGET_MM = 1e-6, 1e-6


@pytest.mark.parametrize("variant", ["paper", "printed"])
@pytest.mark.parametrize("n", [1, 2, 3, 4])
@pytest.mark.parametrize("omega", [90.0, 0.0, 200.0])
def test_tangent_is_limit_of_secant(omega, n, variant):
    scene = Scene(segments=n, variant=variant)
    k = secant_stiffness(scene, forces=(1e-3, 1e-2), angle_deg=omega)
    assert k.ok
    tangent = k.tangent.along(omega)
    errors = [abs(s - tangent) for s in k.stiffness_n_per_m]
    assert errors[0] <= SECANT_LIMIT_RTOL * abs(tangent)
    assert errors[0] < errors[1]  # and the secant converges to it as F -> 0


@pytest.mark.parametrize("n", [2, 3, 4])
def test_tangent_matrix_is_inverse_compliance(n):
    t = tangent_stiffness(solve(Scene(segments=n, payloads=(Payload(1.0),))))
    assert np.allclose(t.compliance, t.compliance.T)
    assert np.all(np.linalg.eigvalsh(t.compliance) > 0)
    assert np.allclose(t.matrix @ t.compliance, np.eye(2), atol=1e-9)
    # directional stiffness is 1 / (u^T C u), not u^T K u: the tip also moves across the force
    assert t.along(90.0) < t.matrix[1, 1]


def test_one_segment_has_no_2x2_stiffness():
    t = tangent_stiffness(solve(Scene(segments=1)))
    assert t.matrix is None
    assert np.linalg.matrix_rank(t.compliance * 1e3, tol=1e-9) == 1
    assert t.to_dict()["matrix_n_per_m"] is None


def test_tangent_compliance_by_finite_differences():
    """dp = C dF at a loaded equilibrium: perturb the tip force and re-solve (warm start)."""
    base = MAIN_JOB
    r0 = solve(base)
    t = tangent_stiffness(r0)
    df = 1e-4
    for k, extra in enumerate([Payload(df, 0.0), Payload(df, 270.0)]):  # +x and +y
        r = solve(base.replace(payloads=base.payloads + (extra,)), theta0=r0.theta)
        dp = (r.tip[:2] - r0.tip[:2]) / 1000.0 / df  # m/N
        assert np.allclose(dp, t.compliance[:, k], rtol=1e-3, atol=1e-7)


def test_tip_jacobian_by_finite_differences():
    r = solve(MAIN_JOB)
    j = tip_jacobian(r.model, r.theta, 135.0)
    h = 1e-7
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        fd = (r.model.tip(r.theta + e, 135.0)[:2] - r.model.tip(r.theta - e, 135.0)[:2]) / (2 * h)
        assert np.allclose(j[:, i], fd, rtol=FD_RTOL, atol=1e-6)


def test_secant_stiffness_paper_definition():
    k = secant_stiffness(Scene(segments=3))
    assert k.ok and k.forces == PAPER_FORCES
    assert k.initial.total_angle_deg == pytest.approx(90.0, abs=1e-9)
    assert k.pressure == pytest.approx(pressure_for_angle(Scene(), 90.0), rel=1e-12)
    # horizontal payload: the displacement along the force is -Delta y, K = 1000 F / delta (N/m)
    for f, delta, kk, r in zip(k.forces, k.displacement_mm, k.stiffness_n_per_m, k.loaded):
        assert delta == pytest.approx(k.initial.tip[1] - r.tip[1])
        assert kk == pytest.approx(1000.0 * f / delta)
    # Section 4.4.3: the stiffness falls as the payload grows
    assert k.stiffness_n_per_m[0] > k.stiffness_n_per_m[1] > k.stiffness_n_per_m[2]
    # the 2 N state is Table 2's
    assert np.allclose(k.loaded[-1].theta_deg, solve(MAIN_JOB).theta_deg, atol=1e-9)
    d = k.to_dict()
    assert len(d["stiffness_n_per_m"]) == 3 and "pressure_mpa" in d and "matrix_n_per_m" in d["tangent"]


def test_secant_uses_scene_pressure_and_rejects_bad_forces():
    k = secant_stiffness(Scene(pressure=0.1), forces=(0.5,))
    assert k.pressure == 0.1
    with pytest.raises(SceneError, match="expected one or more payloads > 0 N"):
        secant_stiffness(Scene(), forces=(0.0,))
    with pytest.raises(SceneError):
        secant_stiffness(Scene(), forces=())


def test_a_payload_too_small_to_resolve_is_refused_naming_it_and_the_bound():
    # 1e-300 N reported ok with K = 2.3e-284 N/m: the displacement was round-off
    for forces in ((1e-300,), (0.5, 1e-12)):
        with pytest.raises(SceneError) as info:
            secant_stiffness(Scene(), forces=forces)
        assert str(info.value).startswith(f"payload {forces[-1]:g} N: below 1e-09 N") and "\n" not in str(info.value)
    k = secant_stiffness(Scene(), forces=(1e-9,))  # at the bound: the secant is the tangent
    assert k.ok and k.stiffness_n_per_m[0] == pytest.approx(k.tangent.along(90.0), rel=1e-4)


def test_tangent_needs_ok_equilibrium():
    r = solve(MAIN_JOB, SolverOptions(max_iter=1, continuation=False))
    with pytest.raises(EquilibriumError, match="stable equilibrium"):
        tangent_stiffness(r)


# ---------------------------------------------------------------------------------------------
# pressure for a target under payloads


@pytest.mark.parametrize("n", [1, 3])
@pytest.mark.parametrize("angle", [30.0, 60.0])
def test_pressure_for_total_angle_vs_root(n, angle):
    scene = MAIN_JOB.replace(segments=n)
    t = pressure_for_target(scene, total_angle_deg=angle)
    assert t.ok, t.message
    assert t.on_load_path
    assert t.equilibrium.total_angle_deg == pytest.approx(angle, abs=TARGET_DEG)
    root = brentq(lambda p: solve(scene, pressure=p).total_angle_deg - angle, 0.05, 0.165, xtol=1e-13)
    assert t.pressure == pytest.approx(root, rel=1e-8)


def test_pressure_for_tip_position():
    t = pressure_for_target(MAIN_JOB, tip_mm=(None, 50.0))
    assert t.ok, t.message
    assert t.equilibrium.tip_mm[1] == pytest.approx(50.0, abs=TARGET_MM)
    # a point on that equilibrium's path is reachable with both coordinates given
    x = t.equilibrium.tip_mm[0]
    t2 = pressure_for_target(MAIN_JOB, tip_mm=(x, 50.0))
    assert t2.ok and t2.pressure == pytest.approx(t.pressure, rel=1e-7)


def test_unreachable_tip_is_reported():
    t = pressure_for_target(MAIN_JOB, tip_mm=(100.0, 50.0))
    assert not t.ok
    assert "not reachable" in t.message and t.residual > 1.0


def test_multistable_target_is_flagged_off_the_load_path():
    """90 deg under 2 N needs ~0.172 MPa raised under the load; inflating first curls it past 200 deg."""
    t = pressure_for_target(MAIN_JOB, total_angle_deg=90.0)
    assert t.ok and not t.on_load_path
    assert "multistable" in t.message
    assert t.equilibrium.total_angle_deg == pytest.approx(90.0, abs=TARGET_DEG)
    assert solve(MAIN_JOB, pressure=t.pressure).total_angle_deg > 200.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({}, "give one of total_angle_deg or tip_mm"),
        ({"total_angle_deg": 10.0, "tip_mm": (1.0, 2.0)}, "give one of total_angle_deg or tip_mm"),
        ({"tip_mm": (None, None)}, "expected [x, y] in mm (one may be None, not both)"),
        ({"tip_mm": (1.0,)}, "expected [x, y] in mm"),
        ({"tip_mm": (float("nan"), 1.0)}, "expected finite numbers in mm"),
        ({"total_angle_deg": float("inf")}, "total_angle_deg=inf: expected a finite number"),
    ],
)
def test_pressure_for_target_errors(kwargs, message):
    with pytest.raises(SceneError) as info:
        pressure_for_target(MAIN_JOB, **kwargs)
    assert message in str(info.value)


def test_stiffness_units_mm_to_m():
    """K in N/m: a compliance of 1 mm/N is 1000 N/m."""
    k = secant_stiffness(Scene(segments=2), forces=(0.5,))
    assert k.stiffness_n_per_m[0] == pytest.approx(0.5 / (k.displacement_mm[0] / 1000.0))
    assert math.isfinite(k.tangent.along(90.0))
