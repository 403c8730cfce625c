"""The actuator's parameters as flags (--L, --r1, --r2, --d, --rho-deg, --E, --M): one definition for
every scene command, named as in a scene file's [actuator] table, validated by the scene's rules."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, build_parser, main
from esba.cli.arguments import ACTUATOR_FLAGS, actuator_flag, scene_from_args
from esba.cli.design import DESIGN_ACTUATOR, _design_actuator
from esba.model.scene import ACTUATOR_RULES, Actuator

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: A value of each field that is not Table 1's and keeps the chamber inside (with the others at Table 1).
NEW = {"L": 120.0, "r1": 9.0, "r2": 2.5, "d": 3.5, "rho_deg": 12.0, "E": 0.6, "M": 0.05}

#: A value of each field its rule refuses, and what the one-line message says.
BAD = {"L": ("0", "> 0"), "r1": ("-1", "> 0"), "r2": ("0", "> 0"), "d": ("-0.5", ">= 0"), "rho_deg": ("90", "0 <= rho_deg < 90"),
       "E": ("-0.2", "> 0"), "M": ("-1", ">= 0")}

#: The commands that take a scene (a scene file and the scene flags).
SCENE_COMMANDS = ("solve", "equilibria", "path", "map", "pressure", "stiffness", "estimate")


def test_flags_are_the_scene_files_fields():
    assert set(ACTUATOR_FLAGS) == set(ACTUATOR_RULES) == {f for f in Actuator.__dataclass_fields__}
    assert {k: v[0] for k, v in ACTUATOR_FLAGS.items()} == {k: v[3] for k, v in ACTUATOR_RULES.items()}
    assert set(NEW) == set(BAD) == set(ACTUATOR_FLAGS)


@pytest.mark.parametrize("command", SCENE_COMMANDS)
@pytest.mark.parametrize("name", list(ACTUATOR_FLAGS))
def test_each_scene_command_takes_each_flag(command, name):
    args = build_parser().parse_args([command, actuator_flag(name), str(NEW[name])])
    scene = scene_from_args(args, payloads=command != "stiffness")
    assert getattr(scene.actuator, name) == NEW[name]
    others = {k for k in ACTUATOR_FLAGS if k != name}
    assert all(getattr(scene.actuator, k) == getattr(Actuator(), k) for k in others)


def test_flags_override_the_scene_file():
    args = build_parser().parse_args(["solve", str(EXAMPLES / "table2.toml"), "--E", "0.7", "--rho-deg", "15"])
    a = scene_from_args(args).actuator
    assert (a.E, a.rho_deg, a.r2) == (0.7, 15.0, 3.0)


@pytest.mark.parametrize("name", list(ACTUATOR_FLAGS))
def test_bad_values_are_refused_in_one_line(capsys, name):
    value, allowed = BAD[name]
    for command in ("solve", "sweep"):
        code = main([command, f"{actuator_flag(name)}={value}", "--json"])
        err = capsys.readouterr().err.strip()
        assert code == EXIT_USAGE and len(err.splitlines()) == 1, err
        assert name in err and allowed in err and value.lstrip("-") in err, err


def test_the_chamber_must_fit(capsys):
    assert main(["solve", "--r2", "5", "--no-plot"]) == EXIT_USAGE
    err = capsys.readouterr().err.strip()
    assert err == "esba: error: actuator.r2=5 with d=4, r1=8: the chamber must lie inside the actuator, r2 + d < r1"
    assert main(["equilibria", "--r1", "abc"]) == EXIT_USAGE
    assert "--r1" in capsys.readouterr().err


def test_solve_json_scene_carries_every_flag(capsys):
    flags = [x for name, v in NEW.items() for x in (actuator_flag(name), f"{v:g}")]
    code = main(["solve", *flags, "--gravity", "--no-plot", "--multistability", "never", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == EXIT_OK
    assert out["scene"].startswith("L=120 r1=9 r2=2.5 d=3.5 rho=12 deg E=0.6 MPa;")


def test_equilibria_json_scene(capsys):
    assert main(["equilibria", "--E", "0.6", "--no-plot", "--json"]) == EXIT_OK
    assert "E=0.6 MPa" in json.loads(capsys.readouterr().out)["scene"]


def test_write_doc_refuses_actuator_flags(capsys, tmp_path):
    assert main(["path", "--write-doc", str(tmp_path / "p.md"), "--E", "0.6"]) == EXIT_USAGE
    assert "--E" in capsys.readouterr().err


@pytest.mark.parametrize("name", list(ACTUATOR_FLAGS))
def test_sweep_takes_each_flag_as_an_axis(capsys, name):
    values = f"{NEW[name]:g},{getattr(Actuator(), name):g}"
    code = main(["sweep", actuator_flag(name), values, "--pressure", "0.1", "--no-progress", "--no-compile", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == EXIT_OK
    assert out["axes"][name]["values"] == [NEW[name], getattr(Actuator(), name)]
    column = {"L": "L_mm", "r1": "r1_mm", "r2": "r2_mm", "d": "d_mm", "rho_deg": "rho_deg", "E": "E_mpa", "M": "M_kg"}[name]
    assert [r[column] for r in out["rows"]] == [NEW[name], getattr(Actuator(), name)]
    assert all(r["status"] == "ok" for r in out["rows"])


def test_sweep_axis_changes_the_answer(capsys):
    """A stiffer rubber bends less at the same pressure; at its 90 degree pressure the bend is 90 whatever E."""
    main(["sweep", "--E", "0.4,0.6", "--pressure", "0.1", "--no-progress", "--no-compile", "--json"])
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert rows[0]["total_angle_deg"] > rows[1]["total_angle_deg"]
    main(["sweep", "--E", "0.4,0.6", "--L", "100,135", "--no-progress", "--no-compile", "--json"])
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [round(r["total_angle_deg"], 6) for r in rows] == [90.0] * 4
    assert len({r["pressure_mpa"] for r in rows}) == 4


@pytest.mark.parametrize("name", DESIGN_ACTUATOR)
def test_design_takes_the_fixed_fields(name):
    args = build_parser().parse_args(["design", actuator_flag(name), str(NEW[name])])
    assert getattr(_design_actuator(args), name) == NEW[name]


def test_design_refuses_what_it_designs(capsys):
    for flag in ("--r2", "--d", "--M"):
        assert main(["design", flag, "1"]) == EXIT_USAGE
        assert "unrecognized arguments" in capsys.readouterr().err


def test_fit_flags_set_the_start(capsys):
    code = main(["fit", str(EXAMPLES / "measurements" / "paper_exp.csv"), "--free", "E", "--E", "0.6", "--rho-deg", "12", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == EXIT_OK
    assert out["parameters"]["E"]["start"] == 0.6


def test_rho_is_also_spelt_as_the_path_and_sigma_names_do(capsys):
    args = build_parser().parse_args(["solve", "--rho", "12"])
    assert scene_from_args(args).actuator.rho_deg == 12.0
    args = build_parser().parse_args(["sweep", "--rho", "5,15"])
    assert args.rho_deg == [5.0, 15.0]
    assert main(["solve", "--rho", "-1", "--no-plot"]) == EXIT_USAGE
    assert "--rho-deg=-1: expected 0 <= rho_deg < 90" in capsys.readouterr().err
