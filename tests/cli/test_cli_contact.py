"""``esba blocked``, ``esba grasp``, and solve / path / equilibria on scenes with obstacles: output and bad input."""

from __future__ import annotations

import json

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main

PROBE = """segments = 3
[loads]
pressure = 0.1
[[obstacles]]
kind = "half-plane"
at = [135.0, 0.0]
normal_deg = 90.0
"""


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_blocked_json_has_forces_shapes_and_kkt(capsys):
    code, out, err = run(capsys, "blocked", "--pressure", "0:0.2:3", "-n", "3", "--json", "--no-plot")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["forces_n"][0] == 0.0 and d["forces_n"][1] < d["forces_n"][2]
    last = d["points"][-1]
    assert last["contacts"][0]["where"] == "tip" and len(last["centreline_mm"]) == 61
    assert last["kkt"]["complementarity_nmm"] <= 1e-8 and last["kkt"]["stability"] == "stable"


def test_blocked_writes_its_figure(capsys, tmp_path):
    code, out, err = run(capsys, "blocked", "--pressure", "0,0.1", "--plot", str(tmp_path / "b.png"))
    assert code == EXIT_OK, err
    assert (tmp_path / "b.png").is_file() and "figure: wrote" in out


def test_grasp_reports_the_first_touch(capsys):
    code, out, err = run(capsys, "grasp", "--pressure", "0:0.2:5", "--no-plot", "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["first_touch"] is not None and 0.05 < d["first_touch"] < 0.15
    assert len(d["contact_length_mm"]) == 5


def test_solve_path_and_equilibria_take_obstacles(capsys, tmp_path):
    scene = tmp_path / "probe.toml"
    scene.write_text(PROBE)
    code, out, err = run(capsys, "solve", str(scene), "--json")
    assert code == EXIT_OK, err
    assert json.loads(out)["contact"]["contacts"][0]["where"] == "tip"
    code, out, err = run(capsys, "path", str(scene), "--to", "0.1", "--no-out", "--no-plot", "--json")
    assert code == EXIT_OK, err
    assert json.loads(out)["forces_n"][-1] > 1.0
    code, out, err = run(capsys, "equilibria", str(scene), "--no-plot", "--json")
    assert code == EXIT_OK, err
    assert json.loads(out)["states"][0]["contacts"][0]["where"] == "tip"


def test_solve_text_with_obstacles_says_what_the_contact_solve_did(capsys, tmp_path):
    scene = tmp_path / "cylinder.toml"
    scene.write_text('segments = 3\n[loads]\npressure = 0.2\n[[obstacles]]\nkind = "cylinder"\ncentre = [90.0, 40.0]\nradius = 12.0\n')
    code, out, err = run(capsys, "solve", str(scene))
    assert code == EXIT_OK, err
    code, js, err = run(capsys, "solve", str(scene), "--json")
    d = json.loads(js)
    c = d["contact"]
    rows = {line.split(":", 1)[0].strip(): line.split(":", 1)[1].strip() for line in out.splitlines()}
    (gap,) = c["gaps_elsewhere_mm"]
    assert rows["gaps"] == f"#1 {gap:.4f} mm (least elsewhere)" and gap > 1.0
    assert rows["stability"].startswith("stable (reduced Hessian eigenvalues (on the constrained set) ")
    assert rows["solver"].startswith(f"contact solve {d['status']}: {c['newton_steps']} load steps by active-set Newton, {c['ipopt_steps']} by IPOPT ")
    assert c["newton_steps"] + c["ipopt_steps"] >= 1 and "path points" not in out
    assert f"({d['iterations']} IPOPT iterations in {c['outer_passes']} passes), {c['halvings']} halved" in rows["solver"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["grasp", "--radius", "-1"], "--radius -1: expected a radius > 0 mm"),
        (["grasp", "--radius", "nan"], "--radius nan: expected a finite number"),
        (["grasp", "--at", "70,nan"], "--at[1]=nan: expected a finite number"),
        (["grasp", "--at", "60,-5", "--radius", "3"], "reaches 8 mm into the actuator at rest"),
        (["grasp", "--at", "70"], "expected X,Y in mm"),
        (["blocked", "--pressure", "0:-0.3:3"], "pressure[1]=-0.15: expected a pressure >= 0 MPa"),
        (["blocked", "--pressure", "nan"], "pressure"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, args, message):
    code, out, err = run(capsys, *args, "--no-plot")
    assert code == EXIT_USAGE
    assert message in err and err.count("\n") == 1, err


def test_a_probe_behind_the_base_in_a_scene_file(capsys, tmp_path):
    scene = tmp_path / "behind.toml"
    scene.write_text(PROBE.replace("at = [135.0, 0.0]", "at = [-10.0, 0.0]"))
    code, out, err = run(capsys, "solve", str(scene))
    assert code == EXIT_USAGE
    assert "the face is behind the base" in err and err.count("\n") == 1
