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
])
def test_bad_3d_obstacles_in_a_scene_file_get_one_line_and_exit_2(tmp_path, capsys, table, message):
    scene = tmp_path / "bad.toml"
    scene.write_text(f"[[obstacles]]\n{table}\n")
    code, out, err = run(capsys, "solve", "--3d", str(scene))
    assert code == EXIT_USAGE
    assert message in err and len(err.strip().splitlines()) == 1 and out == ""
