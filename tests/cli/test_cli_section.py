"""The command line: esba section (the table, --json, a scene file, flags, and bad input in one line)."""

from __future__ import annotations

import json

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.model.section import SECTION_PARAMETERS, section_stiffness


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_section_json_is_the_api_for_table1(capsys):
    code, out, err = run(capsys, "section", "--json")
    assert code == EXIT_OK and err == ""
    data = json.loads(out)
    k = section_stiffness(8.0, 3.0, 4.0, 0.54)
    assert {key: data["inputs"][key] for key in ("r1", "r2", "d", "E", "rho_deg", "layer_width")} == {
        "r1": 8.0, "r2": 3.0, "d": 4.0, "E": 0.54, "rho_deg": 10.0, "layer_width": 8.0}
    assert set(data["inputs"]) == {"r1", "r2", "d", "E", "rho_deg", *SECTION_PARAMETERS}
    assert data["section"]["torsion_constant"] == k.section.torsion_constant
    assert data["section"]["shear_centre"] == list(k.section.shear_centre)
    assert data["stiffness"]["GJ"] == k.GJ and data["stiffness"]["EI_side"] == k.EI_side


def test_section_table_and_flags(capsys, tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text("[actuator]\nr2 = 2.0\nd = 1.0\nE = 1.0\n")
    code, out, _ = run(capsys, "section", str(scene), "--d", "0", "--layer-width", "4", "--mesh", "1")
    assert code == EXIT_OK
    assert out.startswith("section r1=8 r2=2 d=0 mm, E=1 MPa, rho=10 deg")
    k = section_stiffness(8.0, 2.0, 0.0, 1.0, layer_width=4.0, mesh=1)
    assert f"{k.section.torsion_constant:12.3f} mm⁴" in out and f"{k.GJ:12.2f} N·mm²" in out
    assert "(-8.0000, 0.0000)" in out  # the concentric section's shear centre is its centre


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--r2", "5"], "actuator.r2=5 with d=4, r1=8: the chamber must lie inside the actuator"),
        (["--d", "nan"], "actuator.d=nan: expected a finite number"),
        (["--r1", "-8"], "actuator.r1=-8: expected a number > 0"),
        (["--E", "0"], "actuator.E=0: expected a number > 0"),
        (["--rho", "35"], "--rho (or the scene's rho_deg)=35: within 1 deg of 35.26, where the slack fibres lock the twist"),
        (["--fibres", "tight"], "argument --fibres: invalid choice: 'tight'"),
        (["--fibres", "taut", "--fibre-diameter", "-1"], "--fibre-diameter=-1: expected a number > 0"),
        (["--layer-width", "20"], "--layer-width=20: expected a layer narrower than the actuator's diameter"),
        (["--layer-thickness", "-1"], "--layer-thickness=-1: expected a number > 0"),
        (["--nu", "0.7"], "--nu=0.7: expected a Poisson's ratio from 0 to 0.5"),
        (["--fibre-efficiency", "inf"], "--fibre-efficiency=inf: expected a finite number"),
        (["--mesh", "9"], "--mesh=9: expected a whole number from 0 to 4"),
        (["--r2", "0_1"], "'0_1' is not a number"),
        (["missing.toml"], "scene file 'missing.toml'"),
    ],
)
def test_section_refuses_bad_input_in_one_line(capsys, argv, needle):
    code, out, err = run(capsys, "section", *argv)
    assert code == EXIT_USAGE and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("esba: error: ") and needle in lines[0], err


def test_section_warns_when_the_mesh_does_not_resolve_a_thin_wall(capsys):
    code, out, err = run(capsys, "section", "--d", "4.9999", "--mesh", "1", "--json")
    assert code == EXIT_OK and json.loads(out)["section"]["torsion_error"] > 1e-3
    assert err.startswith("esba: warning: the torsion constant's bounds differ by") and "--mesh" in err
    code, out, err = run(capsys, "section")
    assert err == ""  # Table 1 on the default mesh: within 1e-5
