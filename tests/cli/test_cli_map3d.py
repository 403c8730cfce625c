"""The command line: esba map --3d and esba design --cone: a small map, its files, bad input in one line."""

from __future__ import annotations

import json

import pytest

from esba.analysis.maps3d import AXES3D
from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.cli.map3d import MAP3D_PARAMETERS


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_parser_knows_every_3d_parameter():
    assert set(MAP3D_PARAMETERS) == set(AXES3D)


def test_a_3d_map_of_pressure_and_payload_in_the_plane(capsys, tmp_path):
    """A section stiff out of the plane: the pressure paths' losses are the planar folds of docs/maps.md."""
    out_csv = tmp_path / "m.csv"
    code, out, err = run(capsys, "map", "--3d", "--x", "pressure:0.1:0.25", "--y", "payload:2:3", "--pressure", "0",
                         "--section", "EI_side=4e5", "--section", "GJ=1e5", "--resolution", "11", "--history-lines", "2",
                         "--out", str(out_csv), "--no-plot", "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["regions"]["stays in its plane"] == 1.0
    folds = sorted(round(p["pressure"], 8) for p in d["path_points"] if p["payload"] == 2.0)
    assert folds == [0.16360178, 0.1735355]
    text = out_csv.read_text()
    assert text.startswith("source,kind,pressure,payload") and text.count("\npath,fold,") == 4


@pytest.mark.parametrize(
    "args, words",
    [
        (["--3d", "--x", "beta:0:100", "--y", "payload:0:1"], "beta 100: expected an angle from -90 to 90"),
        (["--x", "beta:0:10", "--y", "payload:0:1"], "give --3d"),
        (["--x", "pressure:0:0.2", "--y", "payload:0:1", "--max-twist", "5"], "--max-twist is for the 3-D map"),
        (["--3d", "--x", "pressure:0:0.2", "--y", "payload:0:1", "--max-twist", "0"], "--max-twist 0"),
        (["--3d", "--x", "pressure:0:0.2", "--y", "payload:0:1", "--section", "GJ=-1"], "--section"),
        (["--3d", "--x", "payload2:0:1", "--y", "pressure:0:0.2"], "with --3d the parameter is one of"),
        (["--3d", "--x", "omega:0:90", "--y", "around:0:90"], "cannot be mapped against omega"),
        (["--3d", "--x", "pressure:0:0.2", "--y", "at:0:1"], "at 0: expected a fraction"),
        (["--3d", "--x", "pressure:0:0.2", "--y", "around:0:90", "--no-payload"], "exactly one payload"),
        (["--3d", "--x", "pressure:0:0.2", "--y", "twist:0:1"], "unknown parameter 'twist'"),
        (["--3d", "--x", "tilt:0:1", "--y", "pressure:0:0.2"], "with --3d one of pressure, payload, omega, beta, around, at"),
    ],
)
def test_bad_3d_map_input(capsys, args, words):
    code, out, err = run(capsys, "map", *args, "--no-out", "--no-plot")
    assert code == EXIT_USAGE and words in err and err.count("\n") == 1, err


@pytest.mark.parametrize(
    "args, words",
    [
        (["--cone", "100"], "--cone: cone_deg=100"),
        (["--cone", "10", "--max-twist", "-1"], "--max-twist: max_twist_deg=-1"),
        (["--cone", "10", "--section", "GJ=1e4"], "GJ given alone"),
        (["--cone", "10", "--section", "GJ"], "--section 'GJ': expected NAME=VALUE"),
    ],
)
def test_design_cone_bad_input(capsys, args, words):
    code, out, err = run(capsys, "design", "--envelope-pressure", "0.3", "--envelope-payload", "1", *args)
    assert code == EXIT_USAGE and words in err and err.count("\n") == 1, err


def test_a_3d_map_with_its_fold_and_branch_point_curves(capsys, tmp_path):
    """--fold-curves: the fold curve of the in-plane state (its cusp that of docs/maps.md's first map)
    and the branch-point curve where it flips sideways (eccentric section), printed, in JSON and CSV."""
    out_csv = tmp_path / "m.csv"
    args = ("map", "--3d", "--x", "pressure:0.05:0.3", "--y", "payload:0.2:3", "--pressure", "0", "--payload", "1",
            "--resolution", "11", "--history-lines", "0", "--fold-curves", "--no-plot")
    code, out, err = run(capsys, *args, "--out", str(out_csv), "--json")
    assert code == EXIT_OK, err
    c = json.loads(out)["curves"]
    assert c["fold_summary"]["curves"] == 1 and c["fold_summary"]["cusp"] == 1 and c["notes"] == []
    (cusp,) = [p for p in c["fold_curves"][0]["special_points"] if p["kind"] == "cusp"]
    assert cusp["pressure"] == pytest.approx(0.1685804535, abs=1e-9) and cusp["payload"] == pytest.approx(1.645204063, abs=1e-8)
    assert c["branch_point_summary"] == {"curves": 1, "points": c["branch_point_curves"][0]["points"], "meets an in-plane fold": 0,
                                         "two branch points of the x-path merge": 1, "two branch points of the y-path merge": 1}
    text = out_csv.read_text()
    assert "\nfold curve 0,cusp," in text and "\nbranch-point curve 0,two branch points of the x-path merge," in text
    code, out, err = run(capsys, *args, "--no-out")
    assert code == EXIT_OK and "branch-point curves (continued in pressure and payload): 1" in out and "two branch points of the y-path merge" in out


def test_an_off_plane_payload_map_traces_fold_curves_and_says_why_no_branch_point_curves(capsys):
    code, out, err = run(capsys, "map", "--3d", "--x", "pressure:0.05:0.3", "--y", "payload:1:3", "--pressure", "0", "--payload", "1",
                         "--payload-out-of-plane", "15", "--resolution", "11", "--history-lines", "0", "--fold-curves", "--no-plot", "--no-out", "--json")
    assert code == EXIT_OK, err
    c = json.loads(out)["curves"]
    assert c["fold_summary"]["curves"] >= 1 and c["branch_point_curves"] == [] and "leaves the bending plane" in c["notes"][0]


@pytest.mark.parametrize(
    "args, words",
    [
        (["--x", "pressure:0:0.2", "--y", "payload:0:1", "--fold-curves"], "--fold-curves is for the 3-D map"),
        (["--3d", "--x", "pressure:0:0.2", "--y", "around:0:90", "--fold-curves"], "--y around: around turns two angles"),
    ],
)
def test_bad_fold_curve_input(capsys, args, words):
    code, out, err = run(capsys, "map", *args, "--no-out", "--no-plot")
    assert code == EXIT_USAGE and words in err and err.count("\n") == 1, err
