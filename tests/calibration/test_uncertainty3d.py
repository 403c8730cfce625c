"""Uncertainty in 3-D (esba.calibration.uncertainty3d, esba.analysis.sensitivity3d): first order and
Monte Carlo on the 3-D model, deterministic, the planar answer for in-plane scenes, bad input in one line."""

from __future__ import annotations

import numpy as np
import pytest

from esba.analysis.sensitivity3d import OUTPUTS3D, sensitivities3d, with_parameters3d
from esba.calibration.sigmas import UncertaintyError, parse_sigma, resolve_sigmas
from esba.calibration.uncertainty import MonteCarloOptions, compare, monte_carlo, propagate
from esba.calibration.uncertainty3d import MonteCarlo3D, monte_carlo3d, propagate3d
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import solve
from esba.statics.spatial import check_section, solve_scene3d

#: Out of the plane: a payload 20 deg out of it, a stiff enough section that the state is stable.
SIDE = Scene(pressure=0.12, payloads=(Payload(0.6, 90.0, 0.8, 20.0),))
SECTION = {"EI_side": 4e5, "GJ": 1e5}
#: In the plane, with gravity, and stable in 3-D under the eccentric section's own stiffnesses.
PLANE = Scene(pressure=0.12, payloads=(Payload(0.6, 60.0, 0.8),), gravity=True)
PLANAR_SIGMAS = ("E=10%", "r2=±0.1", "F1=5%", "Omega1=2", "s1=0.02", "L=1", "rho=1", "M=10%")


def _outputs(scene, section):
    eq = solve_scene3d(scene, section)
    return np.r_[eq.tip, np.degrees([np.sum(eq.theta), np.sum(eq.psi), np.sum(eq.tau)])]


def test_the_3d_sensitivities_are_the_derivatives_of_the_3d_solve():
    section = check_section(SECTION, SIDE)
    s = sensitivities3d(SIDE, section, solve_scene3d(SIDE, section))
    assert s.ok
    for name in ("Beta1", "GJ", "EI_side", "E", "Omega1", "F1", "s1"):
        value = next(p.value for p in s.parameters if p.name == name)
        h = 1e-5 * max(abs(value), 1.0)
        minus = _outputs(*with_parameters3d(SIDE, section, {name: value - h}))
        plus = _outputs(*with_parameters3d(SIDE, section, {name: value + h}))
        exact = np.array([s.output(o, name) for o, _ in OUTPUTS3D])
        assert np.abs((plus - minus) / (2 * h) - exact).max() <= 1e-6 * np.abs(exact).max(), name


def test_in_plane_the_3d_first_order_is_the_planar_one_to_1e_10():
    section = check_section({}, PLANE)  # the eccentric section's stiffnesses
    specs = [parse_sigma(t) for t in PLANAR_SIGMAS]
    planar = propagate(solve(PLANE), resolve_sigmas(PLANE, specs))
    spatial = propagate3d(PLANE, section, solve_scene3d(PLANE, section), resolve_sigmas(PLANE, specs, section))
    assert planar.status == spatial.status == "ok"
    for out in ("tip_x", "tip_y", "total_angle"):
        assert spatial.std(out) == pytest.approx(planar.std(out), rel=1e-10, abs=0)
    np.testing.assert_allclose(spatial.cov_tip, planar.cov_tip, rtol=1e-10, atol=1e-12 * np.abs(planar.cov_tip).max())
    np.testing.assert_allclose(spatial.cov_theta, planar.cov_theta, rtol=1e-10, atol=1e-12 * np.abs(planar.cov_theta).max())
    assert spatial.std("tip_z") == spatial.std("sideways") == spatial.std("twist") == 0.0  # nothing leaves the plane


def test_in_plane_the_3d_monte_carlo_has_the_planar_samples():
    section = check_section({}, PLANE)
    specs = [parse_sigma(t) for t in ("E=10%", "F1=5%", "s1=0.02")]
    opts = MonteCarloOptions(samples=60, seed=4, chunk=25)
    planar = monte_carlo(PLANE, resolve_sigmas(PLANE, specs), opts)
    spatial = monte_carlo3d(PLANE, resolve_sigmas(PLANE, specs, section), opts, section=section)
    np.testing.assert_array_equal(spatial.samples, planar.samples)  # the same draws
    np.testing.assert_array_equal(spatial.code, planar.code)
    ok = planar.ok
    assert ok.sum() > 30
    # two solvers (the planar batch path, the 3-D load history) to their tolerances
    assert np.abs(spatial.tip[ok, :2] - planar.tip[ok]).max() <= 1e-9
    assert np.abs(spatial.theta[ok] - planar.theta[ok]).max() <= 1e-11
    assert np.all(spatial.q[ok][:, 3:] == 0.0) and np.all(spatial.tip[ok, 2] == 0.0)


@pytest.fixture(scope="module")
def side():
    section = check_section(SECTION, SIDE)
    sig = resolve_sigmas(SIDE, [parse_sigma(t) for t in ("GJ=5%", "Beta1=±2", "E=3%", "EI_side=5%")], section)
    return section, sig


def test_the_3d_monte_carlo_is_the_same_twice_and_whatever_the_chunks_and_their_order(side):
    section, sig = side
    opts = MonteCarloOptions(samples=40, seed=7, chunk=16)
    first = monte_carlo3d(SIDE, sig, opts, section=section)
    again = monte_carlo3d(SIDE, sig, opts, section=section)
    split = monte_carlo3d(SIDE, sig, opts, section=section, chunks=[3, 20, 1, 16])

    def backwards(scene, fn, bounds, args_of, on_result, progress):  # solved last chunk first, handed back in order
        results = {b: fn(*args_of(*b)) for b in reversed(bounds)}
        for b in bounds:
            on_result(*b, results[b])

    reversed_ = monte_carlo3d(SIDE, sig, opts, section=section, chunks=[11, 9, 20], execute=backwards)
    assert isinstance(first, MonteCarlo3D) and first.counts["ok"] == 40
    for other in (again, split, reversed_):
        for name in ("samples", "code", "q", "tip", "theta", "total_angle"):
            np.testing.assert_array_equal(getattr(other, name), getattr(first, name))
        assert other.to_dict() == first.to_dict()
    assert monte_carlo3d(SIDE, sig, MonteCarloOptions(samples=40, seed=8, chunk=16), section=section).std("twist") != first.std("twist")


def test_3d_first_order_agrees_with_the_monte_carlo_at_small_sigmas(side):
    section, sig = side
    first = propagate3d(SIDE, section, solve_scene3d(SIDE, section), sig)
    mc = monte_carlo3d(SIDE, sig, MonteCarloOptions(samples=400, seed=0, chunk=100), section=section)
    agreement = compare(first, mc)
    assert first.ok and agreement.agree, agreement.verdict
    assert {r["output"] for r in agreement.rows} == {o for o, _ in OUTPUTS3D}
    assert first.std("twist") > 0 and first.std("tip_z") > 0 and first.std("sideways") > 0
    d = first.to_dict()
    assert d["model"] == "3d" and len(d["std_tip_mm"]) == 3 and len(d["std_psi_deg"]) == 3 and sum(d["variance_shares"]["twist"].values()) == pytest.approx(1.0)


def test_a_sideways_unstable_state_has_no_first_order_numbers():
    scene = Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0),))  # Table 2's case flips sideways on the eccentric section
    section = check_section({}, scene)
    u = propagate3d(scene, section, solve_scene3d(scene, section, descend=False), resolve_sigmas(scene, [parse_sigma("E=5%")], section))
    assert u.status == "not_stable" and not u.has_numbers and u.to_dict()["std"]["twist"] is None


@pytest.mark.parametrize("spec, match", [
    ("Beta2=1", "'Beta2' is not a parameter of this 3-D scene"),
    ("Beta1=10%", "Beta1 is 0 in this scene, so a relative sigma is 0"),
    ("twist=1", "'twist' is not a parameter"),
])
def test_bad_3d_sigmas_are_refused_in_one_line(spec, match):
    scene = Scene(pressure=0.1, payloads=(Payload(0.5, 90.0),))
    with pytest.raises(UncertaintyError, match=match):
        resolve_sigmas(scene, [parse_sigma(spec)], check_section(SECTION, scene))


def test_3d_sigmas_need_the_3d_model_and_the_3d_monte_carlo_takes_no_batch_options(side):
    from esba.statics.batch import BatchOptions

    section, sig = side
    with pytest.raises(UncertaintyError, match=r"'GJ' is not a parameter of this scene.*are the 3-D model's: esba solve --3d\)"):
        resolve_sigmas(SIDE, [parse_sigma("GJ=5%")])  # no section: the planar parameters
    with pytest.raises(UncertaintyError, match="samples=100001: at most 100000 in 3-D"):
        monte_carlo3d(SIDE, sig, MonteCarloOptions(samples=100_001), section=section)  # refused before any sample is solved
    with pytest.raises(UncertaintyError, match="batch: a 3-D Monte Carlo"):
        monte_carlo3d(SIDE, sig, MonteCarloOptions(samples=10, batch=BatchOptions()), section=section)
    with pytest.raises(UncertaintyError, match="compare a planar propagation with a planar Monte Carlo"):
        compare(propagate(solve(PLANE), resolve_sigmas(PLANE, [parse_sigma("E=5%")])), monte_carlo3d(SIDE, sig, MonteCarloOptions(samples=10), section=section))


def test_samples_outside_the_rules_are_counted_not_solved():
    section = check_section(SECTION, SIDE)
    sig = resolve_sigmas(SIDE, [parse_sigma("Beta1=±80")], section)  # |20 + t| > 90 for part of the samples
    mc = monte_carlo3d(SIDE, sig, MonteCarloOptions(samples=30, seed=1), section=section)
    bad = np.abs(mc.samples[0]) > 90
    assert bad.any() and np.array_equal(mc.code == 1, bad) and np.all(np.isnan(mc.q[bad]))


@pytest.mark.parametrize("arm", [None, (0.0, 1.0, 0.0)], ids=["joint moment", "couple"])
def test_a_scenes_moments_are_held_and_the_sensitivities_still_the_solves_derivatives(arm):
    from esba.model.scene import Moment

    scene = SIDE.replace(moments=(Moment((0.0, 0.0, 5.0), arm=arm),))
    section = check_section(SECTION, scene)
    s = sensitivities3d(scene, section, solve_scene3d(scene, section), ["GJ", "Beta1", "E"])
    assert s.ok
    for name in ("GJ", "Beta1", "E"):
        value = next(p.value for p in s.parameters if p.name == name)
        h = 1e-5 * max(abs(value), 1.0)
        fd = (_outputs(*with_parameters3d(scene, section, {name: value + h})) - _outputs(*with_parameters3d(scene, section, {name: value - h}))) / (2 * h)
        exact = np.array([s.output(o, name) for o, _ in OUTPUTS3D])
        assert np.abs(fd - exact).max() <= 1e-6 * np.abs(exact).max(), name
