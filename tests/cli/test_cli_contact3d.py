"""``esba solve --3d`` on scenes with 3-D obstacles: the contacts and KKT numbers, and one-line refusals."""

from __future__ import annotations

import json

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main

SPHERE = """
[loads]
pressure = 0.14

[[obstacles]]
kind = "sphere"
centre = [66.0, 52.0, 3.0]
radius = 10.0
"""


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_3d_lists_the_contact_its_force_vector_and_the_kkt_numbers(tmp_path, capsys):
    scene = tmp_path / "sphere.toml"
    scene.write_text(SPHERE)
    code, out, err = run(capsys, "solve", "--3d", str(scene), "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["ok"] and [c["where"] for c in d["contacts"]] == ["inside segment 3"]
    c = d["contacts"][0]
    assert c["force_n"] > 0 and abs(sum(v * v for v in c["direction"]) - 1.0) < 1e-12
    assert d["obstacles"][0]["touches"] == "tube"
    k = d["kkt"]
    assert k["complementarity_nmm"] < 1e-9 and k["stability"] == "stable" and k["min_force_n"] >= 0
    code, out, err = run(capsys, "solve", "--3d", str(scene), "--plot", str(tmp_path / "sphere.png"))
    assert code == EXIT_OK, err
    assert "contacts: inside segment 3" in out and "KKT: stationarity" in out and (tmp_path / "sphere.png").is_file()


@pytest.mark.parametrize("table, message", [
    ('kind = "sphere"\ncentre = [60.0, -8.0, 0.0]\nradius = 3.0', "reaches 11 mm into the actuator at rest"),
    ('kind = "sphere"\ncentre = [60.0, 40.0, 0.0]\nradius = -3.0', "sphere.radius=-3: expected a radius > 0 mm"),
    ('kind = "plane"\nat = [0.0, 0.0, nan]\nnormal = [0.0, 0.0, -1.0]', "plane.at[2]=nan"),
    ('kind = "cylinder"\ncentre = [60.0, 40.0, 0.0]\naxis = [0.0, 0.0, 0.0]\nradius = 5.0', "cylinder.axis=[0, 0, 0]: a zero vector has no direction"),
    ('kind = "plane"\nat = [-10.0, 0.0, 0.0]\nnormal = [1.0, 0.0, 0.0]', "plane.at=[-10, 0, 0]: the point is behind the base"),
])
def test_bad_3d_obstacles_in_a_scene_file_get_one_line_and_exit_2(tmp_path, capsys, table, message):
    scene = tmp_path / "bad.toml"
    scene.write_text(f"[[obstacles]]\n{table}\n")
    code, out, err = run(capsys, "solve", "--3d", str(scene))
    assert code == EXIT_USAGE
    assert message in err and len(err.strip().splitlines()) == 1 and out == ""


def test_path_3d_follows_the_pressure_with_obstacles_and_locates_the_touch_and_the_slides(tmp_path, capsys):
    scene = tmp_path / "sphere.toml"
    scene.write_text(SPHERE)
    code, out, err = run(capsys, "path", "--3d", str(scene), "--to", "0.2", "--json", "--out", str(tmp_path / "path.csv"), "--no-plot")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["ok"] and len(d["points"]) == 31 and d["points"][-1]["pressure_mpa"] == 0.2
    assert [e["kind"] for e in d["events"]] == ["touch", "slide", "slide"]
    touch, into, out_of = d["events"]
    assert touch["after"] == ["inside segment 3"] and abs(touch["pressure_mpa"] - 0.127721) < 1e-6
    assert into["before"] == ["inside segment 3"] and into["after"] == ["inside segment 2", "inside segment 3"]  # across joint 2 (s = 2/3)
    assert out_of["after"] == ["inside segment 2"] and abs(into["s"] - 2.0 / 3.0) < 1e-3
    assert all(e["bracket_mpa"][1] - e["bracket_mpa"][0] <= 1e-6 for e in d["events"])
    assert all(p["kkt"]["complementarity_nmm"] < 1e-9 for p in d["points"])
    rows = (tmp_path / "path.csv").read_text().splitlines()
    assert rows[0].startswith("pressure_mpa,total_force_n,contacts,tip_x_mm") and len(rows) == 32


@pytest.mark.parametrize("flags, message", [
    (("--to", "-1"), "--to=-1: expected a pressure >= 0 MPa"),
    (("--to", "0.2", "--param", "payload"), "--param payload: a scene with obstacles follows the pressure only"),
])
def test_path_3d_with_obstacles_refuses_bad_input_in_one_line(tmp_path, capsys, flags, message):
    scene = tmp_path / "sphere.toml"
    scene.write_text(SPHERE)
    code, out, err = run(capsys, "path", "--3d", str(scene), *flags, "--no-out", "--no-plot")
    assert code == EXIT_USAGE
    assert message in err and len(err.strip().splitlines()) == 1 and out == ""


def test_equilibria_3d_with_obstacles_lists_each_contact_equilibrium(tmp_path, capsys):
    scene = tmp_path / "sphere.toml"
    scene.write_text(SPHERE)
    code, out, err = run(capsys, "equilibria", "--3d", str(scene), "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["three_d"] and d["free_equilibria"] >= 1 and d["states"]
    first = d["states"][0]
    assert first["kkt"]["stability"] == "stable" and [c["where"] for c in first["contacts"]] == ["inside segment 3"]
    code, out, err = run(capsys, "equilibria", "--3d", str(scene))
    assert code == EXIT_OK and "inside segment 3" in out and "bend, side, twist" in out
    code, out, err = run(capsys, "equilibria", "--3d", str(scene), "--no-check")
    assert code == EXIT_USAGE and err.count("\n") == 1 and "--no-check" in err
