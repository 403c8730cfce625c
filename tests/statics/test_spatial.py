"""The planar model is the restriction of the spatial one (issue 26): for loads in the bending plane
the 3-D solve returns zero sideways bend and twist and the planar numbers to 1e-10."""

from __future__ import annotations

import numpy as np
import pytest

from esba.model.generated import load_model
from esba.model.scene import MAIN_JOB
from esba.model.spatial import load_model3d
from esba.statics.equilibrium import solve
from esba.statics.spatial import fold3d, newton3d, solve3d

#: Sideways and torsional stiffnesses large enough that the in-plane state is stable (N*mm^2).
STIFF = dict(EI_side=4e5, GJ=1e6, Beta1=0.0)


def _values(pressure: float) -> dict[str, float]:
    return {**MAIN_JOB.parameters(pressure), **STIFF}


def test_table_2_in_3d_is_the_planar_solution_with_no_sideways_bend_or_twist():
    planar = solve(MAIN_JOB)
    result = solve3d(load_model3d(3), _values(planar.pressure))
    assert result.ok and result.ipopt_status == "Solve_Succeeded", result.notes
    assert np.abs(result.theta - planar.theta).max() < 1e-10
    assert np.abs(result.psi).max() == 0.0 and np.abs(result.tau).max() == 0.0
    assert np.abs(result.tip[:2] - planar.tip[:2]).max() < 1e-9 and result.tip[2] == 0.0


@pytest.mark.parametrize("n", [1, 2, 3])
def test_in_plane_states_have_the_planar_energy_gradient_and_hessian_and_decoupled_blocks(n):
    """At any in-plane state: U, dU/dtheta and the theta-theta block are the planar model's; the
    psi and tau gradients and the blocks coupling them to theta vanish. So every planar fold,
    cusp and buckling load (a zero of the theta block) is one of the 3-D model."""
    m2, m3 = load_model(n), load_model3d(n)
    rng = np.random.default_rng(n)
    for P in (0.05, 0.17):
        vals = {**MAIN_JOB.parameters(P), **STIFF}
        for _ in range(3):
            theta = rng.uniform(-0.1, 1.2, n)
            q = np.concatenate([theta, np.zeros(2 * n)])
            assert m3.energy(q, vals) == pytest.approx(m2.energy(theta, vals), rel=1e-13, abs=1e-12)
            g3, H3, H2 = m3.gradient(q, vals), m3.hessian(q, vals), m2.hessian(theta, vals)
            assert np.abs(g3[:n] - m2.gradient(theta, vals)).max() < 1e-10 * max(1.0, np.abs(g3).max())
            assert np.abs(g3[n:]).max() < 1e-12
            assert np.abs(H3[:n, :n] - H2).max() < 1e-10 * np.abs(H2).max()
            assert np.abs(H3[:n, n:]).max() < 1e-12


def test_the_2_N_pressure_folds_found_in_3d_are_the_planar_ones():
    """Newton on the extended system of the 3-D model finds 0.173535495546 and 0.163601780422 MPa."""
    model = load_model3d(3)
    vals = _values(0.16)
    q = solve3d(model, vals, certify=False).q
    for P in np.linspace(0.16, 0.173, 14):  # up the less bent branch, toward its fold
        vals["P"] = P
        q, ok, _ = newton3d(model, vals, q)
        assert ok
    upper, q_up, v_up = fold3d(model, vals, "P", q)
    assert upper == pytest.approx(0.173535495546, abs=1e-10)
    assert np.abs(q_up[3:]).max() < 1e-15 and np.abs(v_up[3:]).max() < 1e-12  # an in-plane fold
    vals = _values(0.3)
    q = solve3d(model, vals, certify=False).q
    vals["P"] = 0.165  # down the more bent branch
    q, ok, _ = newton3d(model, vals, q)
    lower, _, _ = fold3d(model, vals, "P", q)
    assert lower == pytest.approx(0.163601780422, abs=1e-10)


def test_the_table_2_push_swings_a_torsionally_soft_actuator_out_of_the_plane():
    """The same in-plane state with a silicone-only torsion stiffness (GJ = G pi r1^4 / 2, G = E/3):
    the 3n x 3n Hessian has a negative eigenvalue whose mode is sideways bend and twist only."""
    planar = solve(MAIN_JOB)
    vals = {**_values(planar.pressure), "GJ": 0.54 / 3 * np.pi * 8.0**4 / 2}
    result = solve3d(load_model3d(3), vals, q0=np.concatenate([planar.theta, np.zeros(6)]), certify=False)
    assert result.converged and not result.stable
    assert np.abs(result.mode[:3]).max() < 1e-12 and np.abs(result.mode[6:]).max() > 0.1


def test_first_instability_and_twist_load_of_the_silicone_only_actuator():
    """Pushed in its plane (Table 2's direction) the 90 degree actuator with the silicone's own
    stiffnesses loses a sideways-twist mode (a branch point): stable just below, singular there.
    A tip load out of the plane twists it by 10 degrees at a load found by Brent's method."""
    from esba.model.closed_form import pressure_for_angle
    from esba.statics.spatial import first_instability, load_for_twist

    model = load_model3d(3)
    Ic = np.pi * (8.0**4 - 3.0**4) / 4
    vals = {**MAIN_JOB.parameters(pressure_for_angle(MAIN_JOB.unloaded())), "EI_side": 0.54 * Ic, "GJ": 0.18 * 2 * Ic, "F1": 0.0, "Beta1": 0.0}
    q0 = solve3d(model, vals, certify=False).q
    F, q, mode = first_instability(model, vals, "F1", q0, top=4.0)
    assert 0.0 < F < 2.0 and np.abs(mode[:3]).max() < 1e-10 and np.abs(q[3:]).max() < 1e-14
    assert abs(np.linalg.eigvalsh(model.hessian(q, {**vals, "F1": F}))[0]) < 1e-8
    below, _, _ = newton3d(model, {**vals, "F1": 0.9 * F}, q)
    assert np.linalg.eigvalsh(model.hessian(below, {**vals, "F1": 0.9 * F}))[0] > 0
    side = {**vals, "Omega1": 0.0, "Beta1": np.pi / 2}
    Ft, qt = load_for_twist(model, side, "F1", solve3d(model, side, certify=False).q, angle=np.radians(10.0), top=4.0)
    assert abs(np.sum(qt[6:])) == pytest.approx(np.radians(10.0), abs=1e-10) and np.abs(newton3d(model, {**side, "F1": Ft}, qt)[0] - qt).max() < 1e-9


def test_following_the_pressure_in_3d_reaches_the_upper_fold_state_of_the_damped_newton():
    """follow3d (one compiled Newton call a point) gives the damped Newton's states to 1e-10."""
    from esba.statics.spatial import follow3d

    model = load_model3d(3)
    vals = _values(0.16)
    q0 = solve3d(model, vals, certify=False).q
    path = np.linspace(0.16, 0.173, 14)
    states = follow3d(model, vals, "P", path, q0)
    q = q0
    for P, s in zip(path, states):
        q, ok, _ = newton3d(model, {**vals, "P": P}, q)
        assert ok and np.abs(q - s).max() < 1e-10


def test_a_warm_3d_solve_is_the_damped_newtons_answer():
    from esba.statics.spatial import warm3d

    model = load_model3d(3)
    vals = _values(solve(MAIN_JOB).pressure)
    q = solve3d(model, vals, certify=False).q
    assert np.abs(warm3d(model, vals, q + 1e-3) - q).max() < 1e-10


def test_equilibria_in_3d_find_the_mirror_pair_the_soft_finger_swings_to():
    """Table 2 with stiff sideways bending and torsion: one equilibrium, the planar one, stable.
    With the silicone's own stiffnesses the planar state has out-of-plane negative curvature, and
    two mirror-image out-of-plane states (tip z of opposite sign, equal energy) are the minima."""
    from esba.statics.spatial import SpatialError, equilibria3d

    stiff = equilibria3d(MAIN_JOB, {"EI_side": 4e5, "GJ": 1e6})
    assert len(stiff) == 1 and stiff[0].in_plane and stiff[0].morse_index == 0
    Ic = np.pi * (8.0**4 - 3.0**4) / 4
    soft = equilibria3d(MAIN_JOB, {"EI_side": 0.54 * Ic, "GJ": 0.18 * 2 * Ic})
    low = [s for s in soft if s.morse_index == 0]
    assert len(low) == 2 and not low[0].in_plane and low[0].energy == pytest.approx(low[1].energy, rel=1e-10)
    assert low[0].tip[2] == pytest.approx(-low[1].tip[2], rel=1e-8) and abs(low[0].tip[2]) > 1.0
    planar = [s for s in soft if s.in_plane]
    assert len(planar) == 1 and planar[0].morse_index > 0 and planar[0].energy > low[0].energy
    with pytest.raises(SpatialError, match="only for loads in the bending plane"):
        equilibria3d(MAIN_JOB.replace(payloads=(MAIN_JOB.payloads[0].__class__(2.0, 90.0, 1.0, 10.0),)), {"EI_side": 1.0, "GJ": 1.0})


def test_the_load_history_goes_on_past_a_sideways_branch_point_to_a_stable_flipped_state():
    # Table 2 on the eccentric section: the in-plane state is past its sideways branch point (0.72 N)
    from esba.statics.spatial import solve_scene3d

    scene = MAIN_JOB.replace(pressure=solve(MAIN_JOB).pressure)
    held = solve_scene3d(scene, descend=False)
    assert held.converged and not held.stable and np.abs(held.q[scene.segments:]).max() == 0.0
    r = solve_scene3d(scene)
    assert r.converged and r.stable and r.ipopt_status == "Solve_Succeeded" and r.gradient_norm < 1e-8
    assert any("down its unstable mode" in note and "mirror" in note for note in r.notes)
    twist = np.degrees(np.sum(r.tau))
    assert abs(twist) > 100.0 and abs(np.degrees(np.sum(r.theta)) - 95.1) < 0.1
    again = solve_scene3d(scene)
    assert np.array_equal(again.q, r.q)  # the same mirror state every time


def test_a_load_the_model_does_not_carry_is_refused_in_one_line():
    from esba.statics.spatial import SpatialError

    model = load_model3d(3)
    values = {**MAIN_JOB.parameters(0.12), "EI_side": 4e5, "GJ": 1e6, "Beta1": 0.0}
    with pytest.raises(SpatialError, match=r"^mz1=5\.0: a load that model .* does not carry \(its loads: F1\)") as info:
        solve3d(model, {**values, "mz1": 5.0})
    assert "\n" not in str(info.value)
    with pytest.raises(SpatialError, match="F2=1.0"):
        solve3d(model, {**values, "F2": 1.0})
    assert solve3d(model, {**values, "mz1": 0.0}).stable  # a zero load is no load


def test_solve_scene3d_takes_the_scenes_gravity_direction_unless_told_otherwise():
    from esba.model.scene import Scene
    from esba.statics.spatial import solve_scene3d

    section = {"EI_side": 4e5, "GJ": 1e6}
    sideways = Scene(pressure=0.1, gravity=True, gravity_direction=(0.0, 0.0, 1.0))
    by_file = solve_scene3d(sideways, section)
    by_keyword = solve_scene3d(Scene(pressure=0.1, gravity=True), section, gravity_direction=(0.0, 0.0, 1.0))
    assert np.array_equal(by_file.q, by_keyword.q) and by_file.tip[2] > 0.1  # the weight pulls the tip sideways
    down = solve_scene3d(sideways, section, gravity_direction=(1.0, 0.0, 0.0))  # the keyword overrides the file
    assert abs(down.tip[2]) < 1e-9
