"""Results outside the range the paper's model describes carry a validity list and print warnings."""

from __future__ import annotations

import json

import numpy as np
import pytest

from esba.cli import EXIT_OK, main
from esba.model import validity
from esba.model.scene import MAIN_JOB, Actuator, Payload, Scene
from esba.statics.batch import BatchOptions
from esba.statics.equilibrium import solve
from esba.studies.sweep import sweep

#: One scene per check, each found by solving (n = 3); the set is every check the scene trips.
CASES = {
    "axial_strain": (Scene(actuator=Actuator(L=30.0), target_angle_deg=150.0), {"axial_strain"}),
    "radial_strain": (
        Scene(actuator=Actuator(r2=7.9, d=0.0), pressure=0.0, payloads=(Payload(20.0, 150.0),)),
        {"axial_strain", "radial_strain", "tip_behind_base", "payload_range"},
    ),
    "total_bend": (Scene(actuator=Actuator(L=500.0), target_angle_deg=400.0), {"total_bend"}),
    "tip_behind_base": (Scene(target_angle_deg=270.0), {"tip_behind_base"}),
    "pressure_range": (Scene(actuator=Actuator(E=20.0), pressure=1.2), {"pressure_range"}),
    "payload_range": (Scene(actuator=Actuator(E=50.0), pressure=0.1, payloads=(Payload(12.0),)), {"payload_range"}),
}


@pytest.mark.parametrize("check", list(CASES))
def test_each_check_is_found_by_a_solve(check):
    scene, expected = CASES[check]
    r = solve(scene)
    assert r.ok, r.message  # converged and stable: outside the model's range is not a failed solve
    found = {f.check for f in r.validity}
    assert found == expected
    f = next(f for f in r.validity if f.check == check)
    assert abs(f.value) > f.limit if check != "tip_behind_base" else f.value < f.limit
    assert "\n" not in f.message
    assert r.to_dict()["validity"] == [g.to_dict() for g in r.validity]


def test_clean_table2_solve_has_none(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert solve(MAIN_JOB).validity == ()
    assert main(["solve", "--json", "--no-plot"]) == EXIT_OK
    out, err = capsys.readouterr()
    assert json.loads(out)["validity"] == [] and err == ""


def test_pressure_5_solves_and_warns(capsys, tmp_path, monkeypatch):
    """A pressure far outside the model's range: 8968 degrees of bend, exit 0, a warning line per finding and the list in JSON."""
    monkeypatch.chdir(tmp_path)
    assert main(["solve", "--pressure", "5", "--no-plot", "--json"]) == EXIT_OK
    out, err = capsys.readouterr()
    data = json.loads(out)
    checks = [f["check"] for f in data["validity"]]
    assert checks == ["axial_strain", "total_bend", "tip_behind_base", "pressure_range"]
    assert round(data["total_angle_deg"]) == 8968
    lines = err.strip().splitlines()
    assert len(lines) == 4 and all(line.startswith("esba: warning: ") for line in lines)
    assert "total bend 8968 deg is more than a full turn" in err


def test_target_angle_1e6_is_refused_and_ten_turns_solve_and_warn(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["solve", "--target-angle", "1e6", "--no-plot", "--json"]) == 2  # past ten turns: refused up front
    assert "target_angle_deg=1e+06: expected an angle <= 3600 degrees" in capsys.readouterr().err
    assert main(["solve", "--target-angle", "3600", "--no-plot", "--json"]) == EXIT_OK
    out, err = capsys.readouterr()
    assert {"axial_strain", "total_bend"} <= {f["check"] for f in json.loads(out)["validity"]}
    assert "esba: warning: total bend 3600 deg" in err


def test_radial_strain_on_a_squeezed_chamber():
    """A chamber wider than half the actuator, squeezed: the radial strain passes -1 (assessed directly)."""
    scene = Scene(actuator=Actuator(r2=7.99, d=0.0), pressure=0.0, segments=1)
    theta = [-8.45]
    assert validity.outer_fibre_strain(1, 135.0, 8.0, theta)[0] > -1.01
    found = validity.assess(scene, theta, 0.0, [10.0, 0.0])
    radial = next(f for f in found if f.check == "radial_strain")
    assert radial.value < -1.0 and "chamber-wall radial strain" in radial.message


def test_strains_match_the_paper():
    # outer fibre 2 r1 from the layer: elongation 2 r1 theta_i (Eq. 6) over L / n
    assert validity.outer_fibre_strain(3, 135.0, 8.0, [0.5])[0] == pytest.approx(2 * 8 * 0.5 / 45.0)
    # Eq. (10): Delta r2 from volume conservation; strain Delta r2 / (r1 - r2)
    t, n, L, r1, r2, d = 0.3, 3, 135.0, 8.0, 3.0, 4.0
    dr = np.sqrt((L * r2**2 + n * r1**3 * t) / (L + n * d * t + n * r1 * t)) - r2
    assert validity.chamber_wall_strain(n, L, r1, r2, d, [t])[0] == pytest.approx(dr / (r1 - r2))
    # the widened chamber's strain stays below 1 however far it bends
    assert validity.chamber_wall_strain(3, 135.0, 8.0, 0.5, 0.0, [1e6])[0] < 1.0


def test_sweep_rows_carry_validity(capsys, tmp_path, monkeypatch):
    s = sweep(Scene(), pressure=[0.1, 5.0], options=BatchOptions(compile="never"))
    assert s.validity[0] == () and {f.check for f in s.validity[1]} >= {"axial_strain", "total_bend"}
    rows = s.rows()
    assert rows[0]["validity"] == "" and "total bend" in rows[1]["validity"]
    assert s.to_dict()["outside_model_range"] == 1
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "--pressure", "0.1,5", "--no-progress", "--no-compile"]) == EXIT_OK
    err = capsys.readouterr().err
    assert "esba: warning: 1 point(s) outside the model's range, e.g. outer-fibre axial strain" in err


def test_stiffness_reports_the_findings_of_its_solves(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["stiffness", "--payload", "12", "--json"]) == EXIT_OK
    out, err = capsys.readouterr()
    found = json.loads(out)["validity"]
    assert [f["check"] for f in found] == ["payload_range"] and found[0]["payload_n"] == 12.0
    assert err.strip() == f"esba: warning: {found[0]['message']}"


def test_design_states_carry_validity(capsys, tmp_path, monkeypatch):
    """A design whose target state bends past a full turn says so (each state of each method)."""
    monkeypatch.chdir(tmp_path)
    code = main(["design", "--objective", "pressure", "--min-stiffness", "10", "--target-angle", "400", "--json"])
    out, err = capsys.readouterr()
    assert code == EXIT_OK, err
    found = json.loads(out)["validity"]
    assert [(f["state"], f["check"]) for f in found] == [("target", "total_bend")]
    assert err.strip() == f"esba: warning: {found[0]['message']}"
    assert main(["design", "--json"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["validity"] == []


def test_streamed_sweep_keeps_validity_in_its_file_and_warns(capsys, tmp_path, monkeypatch):
    from esba.studies.sweep import plan_sweep
    from esba.studies.sweep_runner import read_rows, sweep_study

    plan = plan_sweep(Scene(), pressure=[0.1, 5.0])
    study = sweep_study(plan, BatchOptions(compile="never"), chunk=1, out=tmp_path / "s.csv")
    rows = read_rows(tmp_path / "s.csv")
    assert rows[0]["validity"] == "" and "total bend" in rows[1]["validity"]
    assert study.outside == 1 and study.to_dict(rows=False)["outside_model_range"] == 1
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "--pressure", "0.1,5", "--no-progress", "--no-compile", "--resume", "--out", "t.csv"]) == EXIT_OK
    err = capsys.readouterr().err
    assert "esba: warning: 1 point(s) outside the model's range, e.g. total bend" in err  # as a sweep in memory says it
    assert study.tally.counts["total_bend"] == 1


def test_a_sweep_gathered_in_memory_is_bounded_before_it_starts():
    from esba.studies.sweep import MAX_POINTS, SweepError, plan_sweep
    from esba.studies.sweep_runner import sweep_study

    plan = plan_sweep(Scene(), pressure=[0.1] * 1000, payload=[1.0] * 1000)
    assert plan.size > MAX_POINTS
    with pytest.raises(SweepError, match="at most 200000 in memory"):
        sweep_study(plan, BatchOptions(compile="never"))
