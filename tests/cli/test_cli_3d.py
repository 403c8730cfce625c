"""``esba solve --3d`` and the 3-D loads of scenes, flags and the API: answers and one-line refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.model.scene import MAIN_JOB, Payload, Scene, SceneError, scene_from_dict
from esba.model.spatial import load_model3d
from esba.statics.equilibrium import solve
from esba.statics.spatial import SpatialError, check_section, solve_scene3d, tip_compliance

SECTION = ["--section", "EI_side=4e5", "--section", "GJ=1e6"]


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_3d_of_table_2_is_the_planar_answer_with_no_twist(capsys):
    code, out, err = run(capsys, "solve", "--3d", *SECTION, "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert np.allclose(np.radians(d["theta_deg"]), solve(MAIN_JOB).theta, atol=1e-10)
    assert d["psi_deg"] == [0.0] * 3 and d["tau_deg"] == [0.0] * 3 and d["stable"]
    C = np.array(d["tip_compliance"])
    assert C.shape == (6, 6) and np.allclose(C, C.T)


def test_a_payload_out_of_the_plane_picks_the_3d_model_and_moves_the_tip_sideways(capsys):
    code, out, err = run(capsys, "solve", "--payload-out-of-plane", "20", *SECTION, "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["tip_mm"][2] > 0.5 and "20 deg out of plane" in d["scene"]


@pytest.mark.parametrize("args, message", [
    (["solve", "--3d", "--section", "EI_side=-4e5"], "EI_side='-4e5': expected a finite number > 0"),
    (["solve", "--3d", "--section", "EIside=4e5", "--section", "GJ=1"], "section parameter 'EIside': unknown; allowed are EI_side, GJ"),
    (["solve", "--3d", "--section", "GJ=nan", "--section", "EI_side=1"], "GJ='nan': expected a finite number > 0"),
    (["solve", "--3d", "--section", "GJ"], "--section 'GJ': expected NAME=VALUE"),
    (["solve", "--section", "GJ=1"], "--section is for the 3-D model: give --3d"),
    (["solve", "--html", "x.html"], "--html is for the 3-D model: give --3d"),
    (["solve", "--3d", *SECTION, "--html", "x.txt"], "--html"),
    (["solve", "--payload-out-of-plane", "120", *SECTION], "payload.out_of_plane_deg=120: expected an angle from -90 to 90"),
    (["solve", "--payload-out-of-plane", "nan", *SECTION], "out_of_plane_deg"),
    (["equilibria", "--payload-out-of-plane", "10", "--max-bend", "200"], "--plot and --max-bend are not used with --3d"),  # picks the 3-D search
    (["solve", "--3d", *SECTION, "--history", "together"], "--history is not used with --3d"),  # --sensitivities and --sigma are (tests/studies/test_monte_carlo3d.py)
    (["solve", "--3d", "--gravity", "--gravity-direction", "0,0,0", *SECTION], "a zero vector has no direction"),
    (["solve", "--3d", "--gravity", "--gravity-direction", "nan,0,1", *SECTION], "expected three finite numbers"),
    (["solve", "--3d", "--gravity", "--gravity-direction", "down", *SECTION], "expected X,Y,Z, three numbers"),
    (["solve", "--3d", "--gravity-direction", "0,0,1", *SECTION], "--gravity-direction turns the weight: give --gravity"),
    (["solve", "--gravity-direction", "0,0,1"], "--gravity-direction is for the 3-D model"),
])
def test_bad_3d_input_is_refused_in_one_line(capsys, args, message):
    code, _, err = run(capsys, *args)
    assert code == EXIT_USAGE
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_a_planar_scene_file_means_what_it_meant_and_a_3d_one_says_so():
    planar = scene_from_dict({"payloads": [{"force": 1.0, "angle_deg": 90}]})
    assert not planar.needs_3d and planar.payloads[0].out_of_plane_deg == 0.0
    spatial = scene_from_dict({"payloads": [{"force": 1.0, "out_of_plane_deg": 30}]})
    assert spatial.needs_3d
    with pytest.raises(SceneError, match="out_of_plane_deg=30 points out of the bending plane"):
        spatial.model()
    with pytest.raises(SceneError, match="out_of_plane_deg=-91"):
        Payload(1.0, out_of_plane_deg=-91)


def test_the_api_solves_a_sideways_payload_and_twists_the_finger():
    scene = Scene(target_angle_deg=90.0, payloads=(Payload(0.5, 0.0, 1.0, out_of_plane_deg=90.0),))
    r = solve_scene3d(scene, {"EI_side": 4e5, "GJ": 2e4})
    assert r.ok and abs(r.tip[2]) > 0.1 and np.abs(r.tau).max() > 0
    with pytest.raises(SpatialError, match="unknown"):
        check_section({"EI": 1.0, "GJ": 1.0, "EI_side": 1.0})


def test_the_tip_compliance_of_a_straight_rod_has_the_closed_form_rotations():
    """Moments at the tip of a straight rod: rotations L/GJ, L/EI_side, L/EI at any n; the coupling of
    the in-plane moment to the deflection is L^2/(2 EI); the axial direction is rigid."""
    m = load_model3d(3, "rod,payload")
    vals = dict(L=2.0, EI=3.0, EI_side=5.0, GJ=7.0, kappa0=0.0, F1=0.0, Omega1=0.0, Beta1=0.0, s1=1.0)
    C, K = tip_compliance(m, vals, np.zeros(9))
    assert np.diag(C)[3:] == pytest.approx([2 / 7, 2 / 5, 2 / 3], rel=1e-8)
    assert C[1, 5] == pytest.approx(2.0**2 / (2 * 3.0), rel=1e-8) and abs(C[0, 0]) < 1e-12
    assert np.allclose(K @ C @ K, K, atol=1e-6 * np.abs(K).max())


def test_the_numpy_centreline_passes_through_the_generated_segment_ends_and_the_tube_is_drawn(tmp_path, capsys):
    from esba.model.spatial import centreline3d

    m = load_model3d(3)
    q = np.array([0.3, 0.5, 0.2, -0.1, 0.2, 0.05, 0.1, -0.3, 0.2])
    pts, frames = centreline3d(3, q, 135.0, per_segment=4)
    tip, rot, ends = m.pose(q, 135.0)
    assert np.abs(pts[::4] - ends.T).max() < 1e-12 and np.abs(frames[-1] - rot).max() < 1e-12
    code, _, err = run(capsys, "solve", "--payload-out-of-plane", "40", *SECTION, "--plot", str(tmp_path / "tube.png"))
    assert code == EXIT_OK and (tmp_path / "tube.png").stat().st_size > 10_000, err


def test_the_interactive_view_is_one_offline_html_file(tmp_path, capsys):
    page = tmp_path / "view.html"
    code, _, err = run(capsys, "solve", "--payload-out-of-plane", "30", *SECTION, "--html", str(page))
    assert code == EXIT_OK, err
    text = page.read_text()
    assert text.startswith("<!DOCTYPE html>") and "<canvas" in text and '"rings"' in text and "30 deg out of plane" in text
    assert "src=" not in text and "http" not in text  # nothing to fetch: it works offline


def test_a_moment_or_rod_is_refused_by_the_planar_family_and_named():
    from esba.derive.effects import EffectError, EffectSet

    with pytest.raises(EffectError, match="unknown effect 'moment'"):
        EffectSet.parse("air,moment")
    with pytest.raises(EffectError, match="unknown effect 'rod'"):
        EffectSet.parse("rod,payload")
    m = load_model3d(2, "rod,moment")
    assert m.parameters == ("L", "EI_side", "GJ", "EI", "kappa0", "mx1", "my1", "mz1", "sm1")


def test_the_weight_in_3d_is_the_planar_weight_and_turns_with_the_mount():
    """Gravity along x (the paper's) gives the planar gravity solve to 1e-10; along z it bends the
    finger out of its plane."""
    scene = Scene(target_angle_deg=90.0, payloads=(Payload(1.0, 0.0),), gravity=True)
    planar = solve(scene)
    r = solve_scene3d(scene, {"EI_side": 4e5, "GJ": 1e6})
    assert np.abs(r.theta - planar.theta).max() < 1e-10 and np.abs(r.q[3:]).max() == 0.0
    turned = solve_scene3d(scene, {"EI_side": 4e5, "GJ": 1e6}, gravity_direction=(0.0, 0.0, 2.0))
    assert turned.ok and turned.tip[2] > 0.0
    with pytest.raises(SpatialError, match="a zero vector has no direction"):
        solve_scene3d(scene, {"EI_side": 4e5, "GJ": 1e6}, gravity_direction=(0, 0, 0))


def test_section_stiffnesses_not_given_come_from_the_eccentric_section(capsys):
    """EI_side and GJ default to the section's (esba section: silicone, layer and fibres); one given
    keeps its value and the other is the section's."""
    from esba.model.section import section_stiffness

    k = section_stiffness(8.0, 3.0, 4.0, 0.54, rho_deg=10.0)
    code, out, _ = run(capsys, "solve", "--3d", "--payload", "0.5", "--no-plot", "--json")
    d = json.loads(out)
    assert d["section_nmm2"] == pytest.approx({"EI_side": k.EI_side, "GJ": k.GJ}, rel=1e-12)
    code, out, _ = run(capsys, "solve", "--3d", "--payload", "0.5", "--no-plot", "--json", "--section", "GJ=2e4")
    d = json.loads(out)
    assert d["section_nmm2"]["GJ"] == 2e4 and d["section_nmm2"]["EI_side"] == pytest.approx(k.EI_side, rel=1e-12)
    assert d["section_from"].startswith("given in part")


# --- point moments and couples (scene files, flags, the API) ----------------------------------

def test_a_couple_from_flags_twists_the_finger_and_a_scene_file_says_the_same(capsys, tmp_path):
    code, out, err = run(capsys, "solve", "--moment", "200,0,0", "--moment-arm", "0,1,0", *SECTION, "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert "as a couple on arm [0, 1, 0]" in d["scene"] and d["stable"]
    assert sum(d["tau_deg"]) > 0.5  # a positive torque about x twists it positively
    f = tmp_path / "couple.toml"
    f.write_text("[[payloads]]\nforce = 2.0\n\n[[moments]]\nmoment = [200.0, 0.0, 0.0]\narm = [0.0, 1.0, 0.0]\n")
    code, out2, err = run(capsys, "solve", str(f), *SECTION, "--json")
    assert code == EXIT_OK, err
    assert json.loads(out2)["tau_deg"] == d["tau_deg"]


def test_scene_moments_enter_the_3d_values_by_kind():
    from esba.model.scene import Moment
    from esba.statics.spatial import scene_values3d

    scene = MAIN_JOB.replace(moments=(Moment((0.0, 0.0, 50.0), at=0.5), Moment((20.0, 0.0, 0.0), arm=(0.0, 0.0, 2.0))))
    assert scene.needs_3d
    effects, values = scene_values3d(scene, {"EI_side": 4e5, "GJ": 1e6})
    assert (effects.moments, effects.couples) == (1, 1)
    assert (values["mz1"], values["sm1"], values["cx1"], values["az1"], values["sc1"]) == (50.0, 0.5, 20.0, 2.0, 1.0)
    with pytest.raises(SceneError, match="the planar model has no moment term"):
        scene.model()
    assert scene.unloaded().moments == ()


def test_a_couple_about_the_layers_normal_stays_in_the_plane_and_turns_with_the_arm():
    """An in-plane couple (m about z, arm along the actuator) bends it in its plane only; its moment at the
    tip is m cos(tip angle): the gradient of the energy at the solved state balances it."""
    from esba.model.scene import Moment

    scene = MAIN_JOB.replace(payloads=(), moments=(Moment((0.0, 0.0, -40.0), arm=(1.0, 0.0, 0.0)),))
    eq = solve_scene3d(scene, {"EI_side": 4e5, "GJ": 1e6})
    assert eq.ok and np.abs(eq.psi).max() < 1e-12 and np.abs(eq.tau).max() < 1e-12
    free = solve_scene3d(scene.replace(moments=()), {"EI_side": 4e5, "GJ": 1e6})
    assert eq.theta.sum() < free.theta.sum()  # -40 N mm about z opens the bend


@pytest.mark.parametrize("args, message", [
    (["solve", "--moment", "1,2"], "argument --moment: '1,2': expected three numbers X,Y,Z"),
    (["solve", "--moment", "1,2,nan", *SECTION], "moment.moment=nan: expected a finite number"),
    (["solve", "--moment-at", "0.5", *SECTION], "--moment-at given but there is no moment: add --moment MX,MY,MZ"),
    (["solve", "--moment", "10,0,0", "--moment-arm", "1,0,0", *SECTION], "moment.arm=[1, 0, 0]: expected a direction perpendicular to moment=[10, 0, 0]"),
    (["solve", "--moment", "10,0,0", "--moment-arm", "0,0,0", *SECTION], "moment.arm=[0, 0, 0]: a zero vector has no direction"),
    (["solve", "--moment", "10,0,0", "--moment", "0,0,1", "--moment-at", "1", "--moment-at", "0.5", "--moment-at", "0.2", *SECTION],
     "--moment-at given 3 times for 2 moments"),
    (["solve", "--moment", "0,0,1", "--moment-at", "1.5", *SECTION], "moment.at=1.5: expected a fraction of the length"),
])
def test_bad_moments_are_refused_in_one_line(capsys, args, message):
    code, out, err = run(capsys, *args)
    assert code == EXIT_USAGE and out == ""
    assert message in err and len(err.strip().splitlines()) == 1


def test_stiffness_3d_is_the_inverse_of_the_compliance_and_its_plane_block_the_planar_stiffness(capsys):
    from esba.analysis.stiffness import tangent_stiffness

    code, out, err = run(capsys, "stiffness", "--3d", *SECTION, "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    K, C = np.array(d["tip_stiffness"]), np.array(d["tip_compliance"])
    assert d["stable"] and d["coordinates"] == ["x", "y", "z", "rot_x", "rot_y", "rot_z"]
    assert np.abs(K @ C - np.eye(6)).max() < 1e-9 and np.allclose(K, K.T, rtol=0, atol=1e-12 * np.abs(K).max())
    plane = [0, 1, 5]  # x, y and the rotation about z: the bending plane's coordinates, decoupled from the others here
    assert np.all(K[np.ix_(plane, [2, 3, 4])] == 0)
    Kp = K[np.ix_(plane, plane)]
    free_rotation = Kp[:2, :2] - np.outer(Kp[:2, 2], Kp[2, :2]) / Kp[2, 2]  # planar K_tip leaves the tip free to turn
    planar = tangent_stiffness(solve(MAIN_JOB))  # the same state: Table 2's, loaded (N/m, m/N)
    assert np.allclose(free_rotation * 1000, planar.matrix, rtol=1e-6, atol=0)
    assert np.allclose(C[:2, :2] / 1000, planar.compliance, rtol=1e-6, atol=0)


def test_solve_3d_json_carries_the_tip_stiffness_beside_the_compliance(capsys):
    code, out, err = run(capsys, "solve", "--3d", "--no-plot", "--json")  # the eccentric section: the flipped stable state
    assert code == EXIT_OK, err
    d = json.loads(out)
    K, C = np.array(d["tip_stiffness"]), np.array(d["tip_compliance"])
    assert d["stable"] and np.abs(K @ C - np.eye(6)).max() < 1e-9 and np.linalg.eigvalsh(K)[0] > 0
    assert "rotation about x, y, z" in d["tip_matrices"]["order"]


def test_an_unstable_3d_state_has_no_tip_stiffness_and_says_so():
    from esba.analysis.stiffness3d import tip_stiffness3d
    from esba.statics.spatial import scene_values3d, solve3d

    effects, values = scene_values3d(MAIN_JOB)  # the eccentric section: Table 2's in-plane state is a saddle
    model = load_model3d(MAIN_JOB.segments, effects, MAIN_JOB.variant)
    saddle = solve3d(model, values, descend=False)
    t = tip_stiffness3d(model, values, saddle)
    assert not t.stable and t.stiffness is None and t.compliance is None and "not stable" in t.reason
    assert t.to_dict()["tip_stiffness"] is None


@pytest.mark.parametrize("args, message", [
    (["stiffness", "--3d", "--payload", "1", "--payload", "2"], "--payload given 2 times: with --3d it is the one tip payload"),
    (["stiffness", "--3d", "--payload-angle", "30"], "--payload-angle with --3d turns the tip payload of --payload N"),
    (["stiffness", "--section", "GJ=1"], "--section is for the 3-D model: give --3d"),
    (["stiffness", "--gravity-direction", "0,0,1"], "--gravity-direction is for the 3-D model: give --3d"),
    (["stiffness", "--3d", "--gravity", "--gravity-direction", "0,0,0"], "a zero vector has no direction"),
    (["stiffness", "--3d", "--section", "GJ=-1"], "GJ='-1': expected a finite number > 0"),
])
def test_bad_stiffness_3d_input_is_refused_in_one_line(capsys, args, message):
    code, _, err = run(capsys, *args)
    assert code == EXIT_USAGE
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_gravity_direction_from_a_scene_file_picks_the_3d_model_and_the_flag_overrides_it(capsys, tmp_path):
    f = tmp_path / "sideways.toml"
    f.write_text("gravity = true\n[loads]\npressure = 0.1\ngravity_direction = [0, 0, 1]\n")
    code, out, err = run(capsys, "solve", str(f), *SECTION, "--json")
    assert code == EXIT_OK, err
    from_file = json.loads(out)
    assert "gravity along [0, 0, 1]" in from_file["scene"] and from_file["tip_mm"][2] > 0.1
    code, out, err = run(capsys, "solve", "--3d", "--gravity", "--gravity-direction", "0,0,1", "--pressure", "0.1", "--no-payload", "--no-plot", *SECTION, "--json")
    assert code == EXIT_OK, err
    assert np.allclose(json.loads(out)["tip_mm"], from_file["tip_mm"], rtol=0, atol=1e-9)
    code, out, err = run(capsys, "solve", str(f), "--3d", "--gravity-direction", "1,0,0", *SECTION, "--json")  # the flag wins: down again
    assert code == EXIT_OK, err
    down = json.loads(out)
    assert down["tip_mm"][2] == 0.0 and np.allclose(np.radians(down["theta_deg"]), solve(Scene(pressure=0.1, gravity=True)).theta, atol=1e-10)
    code, out, err = run(capsys, "stiffness", str(f), *SECTION, "--json")  # stiffness picks the 3-D model too
    assert code == EXIT_OK and json.loads(out)["tip_stiffness"] is not None, err
