"""The command line: esba path: special points, branch files, the figure, bad input."""

from __future__ import annotations

import csv
import json

import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.cli.path import _PATH_PARAMETERS, DEFAULT_PATH_FIGURE, DEFAULT_PATH_OUT
from esba.paths.problem import PARAMETERS
from tests.figures import drawn
from tests.tolerances import LOCATE_RTOL


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_parser_knows_every_path_parameter():
    assert set(_PATH_PARAMETERS) == set(PARAMETERS)


def test_pressure_path_prints_folds_and_hysteresis(capsys, tmp_path, monkeypatch):
    saved = drawn.record_saved(monkeypatch)
    out_json, fig = tmp_path / "b.json", tmp_path / "b.png"
    code, out, err = run(capsys, "path", "--param", "pressure", "--from", "0", "--to", "0.3", "--payload", "2", "--out", str(out_json), "--plot", str(fig))
    assert code == EXIT_OK, err
    assert out.count("LP fold") == 2 and "hysteresis:" in out and "jumps at the fold" in out
    assert f"wrote {out_json}" in out and f"wrote {fig}" in out
    data = json.loads(out_json.read_text())
    (main_branch,) = data["branches"]
    # the figure shows the branch of the file: the parameter against the total angle, stable solid, unstable dashed
    (ax,) = saved[fig.resolve()].axes
    assert ax.get_xlabel() == "pressure (MPa)" and ax.get_ylabel() == "total bending angle (deg)"
    runs = [ln for ln in drawn.lines(ax) if ln.get_linewidth() == 1.8]
    x, y = drawn.joined(runs)
    assert x.tolist() == main_branch["lambda"] and y == pytest.approx(main_branch["total_angle_deg"])
    assert [ln.get_linestyle() for ln in runs] == ["-", "--", "-"]  # stable, the unstable middle, stable
    assert len([ln for ln in drawn.lines(ax) if ln.get_marker() == "o"]) == 2  # the two folds
    assert {"branch through the start", "stable", "unstable", "fold (LP)", "loading up", "loading down"} <= set(drawn.legend(ax))
    folds = [sp for sp in main_branch["special_points"] if sp["kind"] == "fold"]
    assert [sp["label"] for sp in folds] == ["LP", "LP"] and all(sp["status"] == "converged" for sp in folds)
    assert data["hysteresis"]["width"] == pytest.approx(folds[0]["lambda"] - folds[1]["lambda"], rel=LOCATE_RTOL)
    assert len(main_branch["lambda"]) == main_branch["points"]


def test_json_and_csv(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "path", "--param", "payload", "--pressure", "0", "--payload", "1", "--payload-angle", "180", "--to", "5", "-n", "2", "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)  # strict JSON: no NaN
    labels = [sp["label"] for b in d["branches"] for sp in b["special_points"]]
    assert labels.count("BP") == 1 and len(d["branches"]) == 3  # the straight branch and both sides of the crossing one
    assert (tmp_path / DEFAULT_PATH_OUT).exists() and (tmp_path / DEFAULT_PATH_FIGURE).exists()
    rows = list(csv.DictReader((tmp_path / DEFAULT_PATH_OUT).open()))
    assert {"branch", "kind", "payload1 (N)", "total_angle_deg", "morse_index", "stable", "theta1_deg"} <= set(rows[0])
    # the crossing branches named by the way they bend (theta > 0 bends away from the chamber), not by the
    # sign of their tangent: the side that folds back does so at a positive total angle, away from it
    assert {r["branch"] for r in rows} == {"main", "BP1 away from chamber", "BP1 towards chamber"}
    by_label = {b["label"]: b for b in d["branches"]}
    (fold,) = [sp for b in d["branches"] for sp in b["special_points"] if sp["kind"] == "fold"]
    assert fold in by_label["BP1 away from chamber"]["special_points"] and fold["total_angle_deg"] > 0
    (bp,) = by_label["main"]["special_points"]
    assert bp["bifurcation"] == "transcritical" and bp["cubic"] != 0 and bp["orthogonality"] < 1e-6


def test_the_table_says_what_kind_of_branch_point(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "path", "--param", "payload", "--pressure", "0", "--payload", "1", "--payload-angle", "180", "--to", "5", "-n", "2", "--no-out", "--no-plot")
    assert code == EXIT_OK, err
    assert "converged; transcritical" in out
    assert "BP1 away from chamber:" in out and "BP1 towards chamber:" in out
    assert "away from the chamber (the total angle rises)" in out


def test_the_snapping_window_at_122_19_deg(capsys, tmp_path, monkeypatch):
    """Issue 21: with the default steps one step jumped to a neighbouring branch, a "converged" branch
    point was reported at 1.834173 N and loading did not snap. The path folds at 1.794243 N."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "path", "--param", "payload", "--target-angle", "90", "--payload-angle", "122.19", "--from", "0", "--to", "6", "--no-out", "--no-plot", "--json")
    assert code == EXIT_OK, err
    d = json.loads(out)
    (main,) = [b for b in d["branches"] if b["label"] == "main"]
    assert len(d["branches"]) == 1 and [sp["kind"] for sp in main["special_points"]] == ["fold", "fold"]
    first, second = main["special_points"]
    assert first["lambda"] == pytest.approx(1.794243, abs=1e-6) and first["status"] == "converged"
    assert first["orthogonality"] > 1e-3  # dg/dlambda is not orthogonal to the null vector: a fold
    up, down = d["loading"]
    assert [(j["kind"], round(j["lambda"], 6)) for j in up["jumps"]] == [("fold", 1.794243)]  # it snaps on loading
    assert [(j["kind"], round(j["lambda"], 6)) for j in down["jumps"]] == [("fold", round(second["lambda"], 6))]
    assert not any(abs(sp["lambda"] - 1.834173) < 1e-4 for sp in main["special_points"])


@pytest.mark.parametrize(
    "args, message",
    [
        (["--param", "pressure"], "the following arguments are required: --to"),
        (["--to", "nan"], "--to nan: expected the finite value"),
        (["--param", "presure", "--to", "1"], "argument --param: invalid choice: 'presure'"),
        (["--to", "0.3", "--out", "x.txt"], "--out 'x.txt': '.txt'; expected a file ending in .csv, .json"),
        (["--to", "0.3", "--out", "missing/x.csv"], "the folder 'missing' does not exist"),
        (["--to", "0.3", "--plot", "x.xyz"], "--plot 'x.xyz': unsupported figure format '.xyz'"),
        (["--to", "0.3", "--from", "-1"], "from=-1.0: outside the range of pressure, 0 to inf MPa"),
        (["--param", "payload", "--no-payload", "--to", "1"], "the scene has 0 payloads"),
        (["--param", "omega", "--payload-index", "2", "--to", "100"], "the scene has 1 payload"),
        (["--param", "r2", "--payload-index", "2", "--to", "2"], "--payload-index 2: only means something with --param payload, omega or at"),
        (["--param", "M", "--to", "0.1"], "the mass only acts with gravity"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "path", *args)
    assert code == EXIT_USAGE
    assert err.count("\n") == 1 and err.startswith("esba: error: ") and message in err, err
    assert "Traceback" not in err and out == ""
    assert not (tmp_path / DEFAULT_PATH_OUT).exists()  # refused before anything was computed or written


def test_write_doc_writes_the_page_and_its_figures(capsys, tmp_path, monkeypatch):
    saved = drawn.record_saved(monkeypatch)
    page = tmp_path / "docs" / "paths.md"
    page.parent.mkdir()
    code, out, err = run(capsys, "path", "--write-doc", str(page))
    assert code == EXIT_OK, err
    text = page.read_text()
    for heading in ("## Pressure under the 2 N horizontal tip payload", "## Payload direction", "## The straight actuator", "## What a designer"):
        assert heading in text
    assert f"esba path --write-doc {page}" in text
    for name, xlabel in (("path-pressure-2N.png", "pressure (MPa)"), ("path-omega-2N.png", "omega1 (deg)"), ("path-column-n4.png", "payload1 (N)")):
        file = tmp_path / "docs" / "figures" / name
        assert file.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f"figures/{name}" in text
        (ax,) = saved[file.resolve()].axes
        assert ax.get_xlabel() == xlabel and ax.get_ylabel() == "total bending angle (deg)"
        assert "branch through the start" in drawn.legend(ax)
    assert "nan" not in text.lower()


def test_write_doc_refuses_other_flags(capsys, tmp_path):
    code, out, err = run(capsys, "path", "--write-doc", str(tmp_path / "p.md"), "--to", "0.3")
    assert code == EXIT_USAGE and "give no --to with it" in err


def test_load_factor_from_zero_ends_at_the_scenes_own_state(capsys, tmp_path):
    from esba.model.scene import MAIN_JOB
    from esba.statics.equilibrium import solve

    code, out, err = run(capsys, "path", "--param", "load", "--from", "0", "--to", "1", "--no-out", "--no-plot", "--json", "--points")
    assert code == EXIT_OK, err
    d = json.loads(out)
    assert d["start"]["total_angle_deg"] == pytest.approx(90.0, abs=1e-9)  # unloaded: the 90 degree state
    assert d["branches"][0]["total_angle_deg"][-1] == pytest.approx(solve(MAIN_JOB).total_angle_deg, abs=1e-8)


def test_a_start_inside_the_bistable_range_reaches_to_through_both_folds(capsys):
    """From the lower stable state at 0.168 MPa the branch turns back at the upper fold, runs down
    its unstable middle past the start to the lower fold and then up the far stable branch to --to."""
    code, out, err = run(capsys, "path", "--param", "pressure", "--from", "0.168", "--to", "0.3", "--payload", "2", "--no-out", "--no-plot",
                         "--json")
    assert code == EXIT_OK, err
    main = json.loads(out)["branches"][0]
    assert main["stopped"] == "bound" and main["stop_reason"] == "reached pressure = 0.3 MPa"
    folds = sorted(p["lambda"] for p in main["special_points"] if p["kind"] == "fold")
    assert folds == pytest.approx([0.16360178, 0.17353550], abs=1e-7)


def test_a_branch_that_turns_back_before_to_says_so_and_exits_1(capsys):
    """A slightly inflated actuator pushed along its axis from 2.85 N: the branch folds at 2.904 N and
    runs back down, past its start, out of the window (2.7 to 3 N) before its next fold (2.629 N)."""
    code, out, err = run(capsys, "path", "--param", "payload", "--pressure", "0.001", "--payload", "2.85", "--payload-angle", "180",
                         "--to", "3", "--no-out", "--no-plot", "--no-loading")
    assert code == 1
    assert "turned back and reached payload1 = 2.7 N without reaching 3 N" in out
    assert err.startswith("esba: the branch did not reach --to 3")


def test_a_branch_leaving_the_models_range_warns(capsys):
    """One segment, no payload, inflated to 0.8 MPa: the branch passes its clamp, a full turn and an
    outer-fibre strain of 1; each is a warning line with the first traced point past it, and in JSON."""
    code, out, err = run(capsys, "path", "-n", "1", "--no-payload", "--param", "pressure", "--to", "0.8", "--no-out", "--no-plot", "--json")
    assert code == EXIT_OK
    checks = {v["check"]: v for v in json.loads(out)["validity"]}
    assert {"tip_behind_base", "total_bend", "axial_strain"} <= set(checks)
    assert checks["tip_behind_base"]["lambda"] < checks["total_bend"]["lambda"] < checks["axial_strain"]["lambda"]
    assert err.count("esba: warning: main, from pressure = ") == len(checks)


def test_the_table_2_paths_stay_inside_the_models_range(capsys):
    code, out, err = run(capsys, "path", "--param", "payload", "--to", "0", "--no-out", "--no-plot", "--json")
    assert code == EXIT_OK and json.loads(out)["validity"] == [] and "warning" not in err
