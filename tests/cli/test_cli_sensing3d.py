"""``esba estimate`` and ``esba fit`` with 3-D measurements: flags, 3-D pose files, bad input in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from esba.calibration.sensing3d import predict3d
from esba.cli import main
from esba.model.scene import Payload, Scene

SECTION = {"EI_side": 4e5, "GJ": 1e5}
_R = ",".join(f"tip_R{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))


def _tip_pose(load=(1.0, 60.0, 20.0), pressure=0.15, section=SECTION):
    F, om, be = load
    _, (tip, rot) = predict3d(Scene(pressure=pressure, payloads=(Payload(F, om, 1.0, be),)), section, pressure, [("tip", None), ("rotation", None)])
    return tip, rot


def _fmt(v) -> str:
    return ",".join(repr(float(x)) for x in v)


def test_estimate_from_the_tip_pose_flags(capsys):
    tip, rot = _tip_pose()
    argv = ["estimate", "--pressure", "0.15", "--tip", _fmt(tip), "--sigma-tip", "0.1", "--tip-rotation", _fmt(rot), "--sigma-rotation", "0.2",
            "--section", "EI_side=4e5", "--section", "GJ=1e5", "--starts", "2", "--json"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "NaN" not in out
    d = json.loads(out)
    assert d["model"] == "3d" and d["status"] == "ok" and d["identifiability"]["rank"] == 3
    got = [d["unknowns"][k]["estimate"] for k in ("F1", "Omega1", "Beta1")]
    assert np.allclose(got, [1.0, 60.0, 20.0], atol=1e-8)


def test_estimate_and_fit_from_3d_pose_files(tmp_path, capsys):
    rows = []
    for P in (0.1, 0.15):
        tip, rot = _tip_pose(pressure=P)
        rows.append(f"cup,{P},{_fmt(tip)},0.1,{_fmt(rot)},0.2")
    poses = tmp_path / "trak.csv"
    poses.write_text(f"# a cup held at two pressures\nload,pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm,{_R},rotation_sd_deg\n" + "\n".join(rows) + "\n")
    assert main(["estimate", "--poses", str(poses), "--section", "EI_side=4e5", "--section", "GJ=1e5", "--starts", "0"]) == 0
    out = capsys.readouterr().out
    assert "3-D load estimate: ok" in out and "force vector" in out
    # the same columns with known payloads fit the section's stiffnesses
    truth = {"EI_side": 3e4, "GJ": 1.5e4}
    rows = []
    for P, be in ((0.0, 90.0), (0.15, 90.0), (0.15, 45.0)):
        tip, rot = _tip_pose((0.3, 90.0, be), P, truth)
        rows.append(f"r{P}_{be},{P},0.3,90,{be},{_fmt(tip)},0.1,{_fmt(rot)},0.2")
    fit = tmp_path / "fit3d.csv"
    fit.write_text(f"label,pressure_mpa,payload_n,payload_angle_deg,payload_out_of_plane_deg,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm,{_R},rotation_sd_deg\n"
                   + "\n".join(rows) + "\n")
    assert main(["fit", str(fit), "--section", "EI_side=1e4", "--section", "GJ=1e4", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["status"] == "ok"
    assert d["parameters"]["EI_side"]["estimate"] == pytest.approx(3e4, rel=1e-8)
    assert d["parameters"]["GJ"]["estimate"] == pytest.approx(1.5e4, rel=1e-8)


@pytest.mark.parametrize("argv, match", [
    (["--pressure", "0.15", "--tip-rotation", "1,0,0,0,1,0,0,0,2", "--sigma-rotation", "0.2"], "--tip-rotation: rotation: not a rotation matrix"),
    (["--pressure", "0.15", "--tip-rotation", "1,0,0,0,1,0,0,0", "--sigma-rotation", "0.2"], "expected 9 numbers"),
    (["--pressure", "0.15", "--tip", "100,50,nan", "--sigma-tip", "0.1"], "--tip"),
    (["--pressure", "0.15", "--angles", "1,2,3", "--sigma-angles", "0.1"], "3n = 9"),
    (["--pressure", "0.15", "--tip", "100,50,3"], "--sigma-tip"),
    (["--pressure", "0.15", "--3d", "--theta", "1,2,3", "--sigma-theta", "0.1"], "--theta"),
    (["--pressure", "0.15", "--tip", "100,50,3", "--sigma-tip", "0.1", "--free", "weight"], "free 'weight'"),
    (["--pressure", "0.15", "--tip", "100,50,3", "--sigma-tip", "0.1", "--section", "GJ=-1"], "GJ"),
    (["--pressure", "0.15", "--3d"], "nothing measured in 3-D"),
])
def test_estimate_bad_3d_input_exits_2_with_one_line(argv, match, capsys):
    assert main(["estimate", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert match in err


@pytest.mark.parametrize("text, match", [
    (f"pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm,{_R},rotation_sd_deg\n0.15,100,50,3,0.1,1,0,0,0,1,0,0,0,1.5,0.2\n",
     "line 2: rotation: not a rotation matrix"),
    ("pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm\n0.15,100,nan,3,0.1\n", "tip_y_mm"),
    ("pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm\n0.15,100,50,0.1\n", "line 2: 4 cells for 5 columns"),
    ("pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm\n0.15,100,50,3\n", "without tip_sd_mm"),
    ("pressure_mpa,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm,payload_n\n0.15,100,50,3,0.1,1\n", "payload_n is given"),
    ("pressure_mpa,tip_x_mm,tip_z_mm,tip_sd_mm,tip_w_mm\n0.15,100,50,3,0.1\n", "unknown column 'tip_w_mm'"),
])
def test_bad_3d_pose_files_exit_2_naming_file_and_field(tmp_path, text, match, capsys):
    f = tmp_path / "p.csv"
    f.write_text(text)
    assert main(["estimate", "--poses", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err and "p.csv" in err


def test_fit_3d_file_bad_input(tmp_path, capsys):
    f = tmp_path / "m.csv"
    f.write_text("pressure_mpa,payload_n,payload_out_of_plane_deg,tip_x_mm,tip_y_mm,tip_z_mm,tip_sd_mm\n0.15,0.3,90,100,50,3,0.1\n")
    for argv, match in ((["--free", "E,rho"], "free 'E'"), (["--plot", str(tmp_path / "x.png")], "--plot is not used with a 3-D file")):
        assert main(["fit", str(f), *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and match in err
    g = tmp_path / "planar.csv"
    g.write_text("label,pressure_mpa,total_angle_deg,total_angle_sd_deg\nfree bend,0.2,176.8,1.0\n")
    assert main(["fit", str(g), "--section", "GJ=1e4"]) == 2
    assert "--section is for a 3-D file" in capsys.readouterr().err
