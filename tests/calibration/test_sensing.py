"""The load estimate (esba estimate): synthetic shapes made by the model itself, noise with a fixed seed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from esba.calibration.poses import load_poses
from esba.calibration.sensing import Measured, Pose, SensingError, SensingOptions, estimate_load, information
from esba.cli import main
from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import solve

Z95 = 1.959963984540054


def _shape(pressure: float, force: float, omega: float) -> np.ndarray:
    r = solve(Scene(pressure=pressure, payloads=(Payload(force, omega),)))
    assert r.ok
    return np.asarray(r.theta_deg)


def _start(pressure: float) -> Scene:
    return Scene(pressure=pressure, payloads=(Payload(1.0, 90.0),))


@pytest.mark.slow
@pytest.mark.ci
def test_intervals_cover_the_true_load_in_95_percent_of_200_random_cases():
    rng = np.random.default_rng(17)
    covered_f = covered_o = misfits = 0
    for _ in range(200):
        p, f, om = rng.uniform(0.08, 0.2), rng.uniform(0.5, 2.5), rng.uniform(-180.0, 180.0)
        noisy = tuple(_shape(p, f, om) + rng.normal(0.0, 0.1, 3))
        # the starts all round, without the equilibria search (it only adds loads on other branches,
        # tested below): the intervals are what is tested here
        e = estimate_load(Pose(p, (Measured("theta", noisy, 0.1),)), ("F1", "Omega1"), _start(p), SensingOptions(branches=False))
        # under the stated noise a fit is called a misfit (chi-square p < MISFIT_P) about once in 1/MISFIT_P
        assert e.status in ("ok", "misfit") and e.identifiable
        misfits += e.status == "misfit"
        lo, hi = e.interval[0]
        covered_f += lo <= f <= hi
        d_omega = (e.estimate[1] - om + 180.0) % 360.0 - 180.0
        covered_o += abs(d_omega) <= Z95 * e.std_error[1]
    assert 0.93 <= covered_f / 200 <= 0.97
    assert 0.93 <= covered_o / 200 <= 0.97
    assert misfits <= 3  # 200 MISFIT_P = 0.2 expected


def test_noise_free_segment_angles_give_the_load_back_from_far_starts():
    theta = _shape(0.15, 1.3, 60.0)
    e = estimate_load(Pose(0.15, (Measured("theta", tuple(theta), 0.05),)), ("force", "angle"), _start(0.15))
    assert e.ok and e.unique and e.identifiable
    assert e.value("F1") == pytest.approx(1.3, abs=1e-7)
    assert e.value("Omega1") == pytest.approx(60.0, abs=1e-5)
    assert e.chi2 < 1e-12
    # the interval comes from the Fisher matrix of the stated deviations: halving them halves it
    half = estimate_load(Pose(0.15, (Measured("theta", tuple(theta), 0.025),)), ("force", "angle"), _start(0.15))
    assert half.std_error == pytest.approx(e.std_error / 2.0, rel=1e-6)


def test_a_tip_load_seen_only_through_the_total_angle_is_not_separable():
    r = solve(Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 90.0),)))
    pose = Pose(None, (Measured("total_angle", (r.total_angle_deg,), 0.1),), target_angle_deg=90.0)
    e = estimate_load(pose, ("force", "angle"), Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 90.0),)))
    assert not e.identifiable and not e.unique
    assert len(e.undetermined) == 1
    assert "do not separate the payload's magnitude and direction: from the total angle alone, only a combination" in e.undetermined[0]
    assert "the total angle alone" in e.undetermined[0]
    assert np.all(np.isnan(e.std_error))
    assert json.loads(json.dumps(e.to_dict()))["unknowns"]["F1"]["std_error"] is None
    # with the direction known, the same angle gives the magnitude
    known = estimate_load(pose, ("force",), Scene(target_angle_deg=90.0, payloads=(Payload(0.3, 90.0),)))
    assert known.identifiable and known.value("F1") == pytest.approx(1.0, abs=1e-6)


def test_a_tip_position_alone_does_not_determine_the_point():
    info = information(Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 90.0),)), [Measured("tip", (0.0, 0.0), 0.1)], ("F1", "Omega1", "s1"))
    assert len(info.undetermined) == 1 and "point" in info.undetermined[0] and "a tip position alone" in info.undetermined[0]


def test_one_object_lifted_at_several_pressures_is_one_load(tmp_path):
    rows = ["label,load,pressure_mpa,total_angle_deg,total_angle_sd_deg"]
    for p in (0.08, 0.12, 0.16, 0.2):
        r = solve(Scene(pressure=p, payloads=(Payload(1.5, 30.0),)))
        rows.append(f"P{p},cup,{p},{r.total_angle_deg:.6f},0.01")
    f = tmp_path / "lift.csv"
    f.write_text("\n".join(rows) + "\n")
    poses = load_poses(f)
    assert {p.load for p in poses} == {"cup"}
    e = estimate_load(poses, ("force", "angle"), _start(0.1))
    # one angle per pose cannot separate magnitude and direction; four pressures can
    assert e.ok and e.identifiable and e.labels == ("F1", "Omega1")
    assert e.value("F1") == pytest.approx(1.5, abs=1e-4) and e.value("Omega1") == pytest.approx(30.0, abs=1e-2)


def test_two_loads_in_one_file_are_estimated_separately(tmp_path):
    rows = ["label,pressure_mpa,theta1_deg,theta2_deg,theta3_deg,theta_sd_deg"]
    for label, (p, f, om) in {"a": (0.1, 1.0, 0.0), "b": (0.15, 2.0, 90.0)}.items():
        t = _shape(p, f, om)
        rows.append(f"{label},{p}," + ",".join(f"{v:.8f}" for v in t) + ",0.1")
    path = tmp_path / "two.csv"
    path.write_text("\n".join(rows) + "\n")
    e = estimate_load(load_poses(path), ("force", "angle"), _start(0.1))
    assert e.labels == ("F1[a]", "Omega1[a]", "F1[b]", "Omega1[b]")
    assert e.estimate == pytest.approx([1.0, 0.0, 2.0, 90.0], abs=1e-4)
    assert e.correlation[0, 2] == pytest.approx(0.0, abs=1e-9)  # separate loads, separate poses


def test_the_actuators_uncertainty_carried_widens_the_interval():
    theta = _shape(0.15, 1.0, 90.0)
    pose = Pose(0.15, (Measured("theta", tuple(theta), 0.1),))
    frozen = estimate_load(pose, ("force", "angle"), _start(0.15))
    carried = estimate_load(pose, ("force", "angle"), _start(0.15), carried=("E",), carried_covariance=[[0.027**2]])
    assert carried.value("F1") == pytest.approx(frozen.value("F1"), abs=1e-6)
    assert carried.std_error[0] > 1.5 * frozen.std_error[0]


def test_an_unstable_explanation_is_flagged_and_a_stable_one_preferred():
    # a tip position with three unknowns: a continuum; the estimate is one the actuator can hold
    r = solve(Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 90.0),)))
    pose = Pose(None, (Measured("tip", tuple(r.tip[:2]), 0.1),), target_angle_deg=90.0)
    e = estimate_load(pose, ("force", "angle", "at"), Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 90.0),)))
    assert e.states[0]["stable"] and e.status == "ok"


@pytest.mark.parametrize("call, match", [
    (lambda: Measured("tip", (1.0,), 0.1), "tip=.*expected 2 values"),
    (lambda: Measured("theta", (1.0, float("nan")), 0.1), "theta"),
    (lambda: Measured("total_angle", (1.0,), 0.0), "sd=0"),
    (lambda: Measured("marker", (1.0, 2.0), 0.1), "marker at"),
    (lambda: Pose(None, (Measured("total_angle", (1.0,), 0.1),)), "pressure"),
    (lambda: SensingOptions(level=1.5), "level=1.5"),
    (lambda: SensingOptions(starts=-1), "starts=-1"),
    (lambda: estimate_load([], ("force",)), "poses"),
    (lambda: estimate_load(Pose(0.1, (Measured("theta", (1.0, 2.0), 0.1),)), ("force",)), "2 values; the scene has 3 segments"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("E",)), "free 'E'"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F2",)), "1 payload"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F1",), carried=("E",), carried_covariance=[[-1.0]]),
     "positive semi-definite"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F01",)), "free 'F01'"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F\u0661",)), "free"),
    (lambda: Measured(["theta"], (1.0,), 0.1), "measured kind"),
    (lambda: Pose(0.1, (Measured("total_angle", (1.0,), 0.1),), target_angle_deg=90.0), "give one of the two"),
    (lambda: Pose(1e300, (Measured("total_angle", (1.0,), 0.1),)), "pressure=1e\\+300 MPa"),
    (lambda: Pose(None, (Measured("total_angle", (1.0,), 0.1),), target_angle_deg=1e9), "target_angle_deg=1e\\+09"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F1",), carried=("E", "E"), carried_covariance=np.eye(2) * 1e-4),
     "given twice"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F1",), carried_covariance=[[1e-4]]), "without carried"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F1",), carried=("E",), carried_covariance=[[1e300]]),
     "exceeds its value"),
    (lambda: estimate_load(Pose(0.1, (Measured("total_angle", (1.0,), 0.1),)), ("F1",), Scene(payloads=(Payload(1.0),)).replace(E=1e300)), "E"),
])
def test_bad_input_is_refused_with_the_field_named(call, match):
    with pytest.raises(SensingError, match=match):
        call()


def test_cli_json_and_table(capsys):
    assert main(["estimate", "--pressure", "0.15", "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.05", "--free", "force,angle", "--json"]) == 0
    out = capsys.readouterr().out
    assert "NaN" not in out
    d = json.loads(out)
    assert d["status"] == "ok" and d["unique"] and d["unknowns"]["F1"]["estimate"] == pytest.approx(1.2998, abs=1e-3)
    assert main(["estimate", "--target-angle", "90", "--total-angle", "60", "--sigma-total-angle", "0.5", "--json"]) == 0
    captured = capsys.readouterr()
    assert "NaN" not in captured.out and "not separate" in captured.err
    assert json.loads(captured.out)["unknowns"]["F1"]["std_error"] is None


@pytest.mark.parametrize("argv, match", [
    (["--pressure", "0.1"], "nothing measured"),
    (["--theta", "1,2,3", "--sigma-theta", "0.1"], "give the pressure"),
    (["--pressure", "0.1", "--theta", "1,2,3"], "--sigma-theta"),
    (["--pressure", "0.1", "--theta", "1,,3", "--sigma-theta", "0.1"], "none empty"),
    (["--pressure", "0.1", "--tip", "1", "--sigma-tip", "0.1"], "expected 2 or 3 numbers"),
    (["--pressure", "0.1", "--marker", "0.5", "--sigma-marker", "0.1"], "AT:X,Y"),
    (["--pressure", "0.1", "--total-angle", "60", "--sigma-total-angle", "0"], "standard deviation"),
    (["--pressure", "0.1", "--total-angle", "60", "--sigma-total-angle", "1", "--free", "E"], "free 'E'"),
    (["--pressure", "0.1", "--total-angle", "60", "--sigma-total-angle", "1", "--sigma", "F1=10%"], "not an actuator parameter"),
    (["--poses", "missing.csv"], "missing.csv"),
])
def test_cli_bad_input_exits_2_with_one_line(argv, match, capsys):
    assert main(["estimate", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert match in err


def test_pose_file_errors_name_the_line(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("pressure_mpa,total_angle_deg\n0.1,60\n")
    with pytest.raises(Exception, match=r"line 2: total_angle_deg is given without total_angle_sd_deg"):
        load_poses(f)
    f.write_text("pressure_mpa,tip_x_mm,tip_sd_mm\n0.1,60,1\n")
    with pytest.raises(Exception, match=r"line 2: tip_x_mm and tip_y_mm go together"):
        load_poses(f)
    f.write_text("pressure_mpa,weight\n0.1,60\n")
    with pytest.raises(Exception, match=r"line 1: unknown column 'weight'"):
        load_poses(f)


def test_two_loads_that_explain_the_same_angle_in_the_bistable_window_are_both_listed():
    # P = 0.17 MPa under 2 N: at Omega = 90 deg the actuator is bistable (212.84 and 83.90 deg); the
    # 83.90 deg state is the one inflating and then loading does not reach. Its total angle, with the
    # direction free, is explained as well by a load at about -10 deg that the history does reach.
    base = Scene(pressure=0.17, payloads=(Payload(2.0, 0.0),))
    e = estimate_load(Pose(0.17, (Measured("total_angle", (83.90,), 0.5),)), ("Omega1",), base)
    assert not e.unique and len(e.alternatives) == 2
    omegas = sorted(float(c.estimate[0]) for c in e.alternatives)
    assert omegas[0] == pytest.approx(-10.0, abs=0.1) and omegas[1] == pytest.approx(90.0, abs=0.01)
    assert all(all(c.stable) for c in e.alternatives)
    assert any("not unique: 2 loads" in w for w in e.warnings)
    d = e.to_dict()
    assert len(d["alternatives"]) == 2 and all(a["states"][0]["total_angle_deg"] == pytest.approx(83.90, abs=1e-6) for a in d["alternatives"])


def test_a_shape_no_load_history_reaches_is_explained_through_the_equilibria_search():
    # the bistable window's second state (83.90 deg under 2 N horizontal at 0.17 MPa): no start's load
    # history reaches it; the other stable states of the start loads do
    e = estimate_load(Pose(0.17, (Measured("total_angle", (83.90,), 0.05),)), ("F1",), Scene(pressure=0.17, payloads=(Payload(1.0, 90.0),)))
    assert e.ok and e.unique and e.value("F1") == pytest.approx(2.0, abs=1e-3)
    assert not e.states[0]["on_load_history"]
    assert any("reaches another state (total angle 212.84 deg)" in w for w in e.warnings)
    without = estimate_load(Pose(0.17, (Measured("total_angle", (83.90,), 0.05),)), ("F1",), Scene(pressure=0.17, payloads=(Payload(1.0, 90.0),)),
                            SensingOptions(branches=False))
    assert without.chi2 > 1e3  # from the load histories alone nothing explains it


def test_cli_carries_a_fits_covariance(tmp_path, capsys):
    fit = {"parameters": {"E": {"estimate": 0.55, "std_error": 0.02}}, "covariance": [[0.0004]]}
    (tmp_path / "fit.json").write_text(json.dumps(fit))
    argv = ["estimate", "--pressure", "0.15", "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.05", "--json"]
    assert main(argv) == 0
    frozen = json.loads(capsys.readouterr().out)["unknowns"]["F1"]["std_error"]
    assert main([*argv, "--fit", str(tmp_path / "fit.json")]) == 0
    carried = json.loads(capsys.readouterr().out)["unknowns"]["F1"]["std_error"]
    pose = Pose(0.15, (Measured("theta", (11.88, 21.31, 33.05), 0.05),))
    same = estimate_load(pose, ("force", "angle"), Scene(pressure=0.15, payloads=(Payload(2.0, 90.0),)).replace(E=0.55),
                         carried=("E",), carried_covariance=[[0.0004]])
    assert carried == pytest.approx(same.std_error[0], rel=1e-6) and carried > frozen
    (tmp_path / "bad.json").write_text("{}")
    assert main([*argv, "--fit", str(tmp_path / "bad.json")]) == 2
    assert "expected the JSON of `esba fit --json`" in capsys.readouterr().err


def test_two_payloads_are_separated_where_the_segment_angles_can_tell_them_apart():
    true = Scene(pressure=0.12, payloads=(Payload(1.0, 0.0), Payload(0.8, 90.0, at=0.5)))
    theta = tuple(solve(true).theta_deg)
    start = true.replace(payloads=(Payload(0.2, 0.0), Payload(0.2, 90.0, at=0.5)))
    e = estimate_load(Pose(0.12, (Measured("theta", theta, 0.01),)), ("F1", "F2"), start)
    assert e.ok and e.identifiable and e.unique
    assert e.estimate == pytest.approx([1.0, 0.8], abs=1e-6)


def test_a_misfit_with_no_degrees_of_freedom_left_is_said(tmp_path):
    pose = Pose(0.15, (Measured("tip", (-9999.0, 9999.0), 1e-3),))
    e = estimate_load(pose, ("force", "angle"), _start(0.15), SensingOptions(starts=2, branches=False))
    assert e.dof == 0 and e.status == "misfit" and not e.ok and "no load explains the data" in e.message


def test_a_lone_carried_name_is_one_name():
    theta = tuple(_shape(0.15, 1.0, 90.0))
    e = estimate_load(Pose(0.15, (Measured("theta", theta, 0.1),)), ("force", "angle"), _start(0.15), carried="rho", carried_covariance=[[1.0]])
    assert e.ok and e.value("F1") == pytest.approx(1.0, abs=1e-5)


@pytest.mark.parametrize("argv, match", [
    (["--free", "F01"], "free 'F01'"),
    (["--sigma", "E=1e300"], "exceeds its value"),
    (["--pressure", "1e300"], "pressure=1e+300 MPa"),
    (["--frozen"], "--frozen takes the values of --fit"),
])
def test_cli_hostile_values_exit_2(argv, match, capsys):
    base = ["estimate", "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.05"]
    if "--pressure" not in argv:
        base += ["--pressure", "0.15"]
    assert main([*base, *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err


def test_cli_a_scene_file_without_a_pressure_is_not_a_measured_pressure(tmp_path, capsys):
    (tmp_path / "s.toml").write_text("segments = 3\n")
    assert main(["estimate", str(tmp_path / "s.toml"), "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.05"]) == 2
    assert "sets neither" in capsys.readouterr().err
    (tmp_path / "p.toml").write_text("[loads]\npressure = 0.15\n")
    assert main(["estimate", str(tmp_path / "p.toml"), "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.05", "--json"]) == 0


def test_cli_frozen_takes_the_fits_values_without_its_covariance(tmp_path, capsys):
    (tmp_path / "fit.json").write_text(json.dumps({"parameters": {"E": {"estimate": 0.55}}, "covariance": [[0.0004]]}))
    # angles of E = 0.54 read at E = 0.55: within 0.5 deg (at 0.05 deg no load explains them, a misfit)
    argv = ["estimate", "--pressure", "0.15", "--theta", "11.88,21.31,33.05", "--sigma-theta", "0.5", "--json", "--fit", str(tmp_path / "fit.json")]
    assert main([*argv, "--frozen"]) == 0
    frozen = json.loads(capsys.readouterr().out)["unknowns"]["F1"]["std_error"]
    same = estimate_load(Pose(0.15, (Measured("theta", (11.88, 21.31, 33.05), 0.5),)), ("force", "angle"),
                         Scene(pressure=0.15, payloads=(Payload(2.0, 90.0),)).replace(E=0.55))
    assert frozen == pytest.approx(same.std_error[0], rel=1e-9)


def test_pose_file_marker_point_without_its_position_is_refused(tmp_path):
    f = tmp_path / "m.csv"
    f.write_text("pressure_mpa,marker_at,total_angle_deg,total_angle_sd_deg\n0.1,0.5,60,1\n")
    with pytest.raises(Exception, match="marker_at is given without marker_x_mm"):
        load_poses(f)
