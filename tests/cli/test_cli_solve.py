"""The command line: esba solve / stiffness / pressure / validate, their JSON, figures and errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from esba.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, main
from esba.cli.scenes import DEFAULT_SOLVE_FIGURE
from esba.model.scene import MAIN_JOB
from esba.statics.equilibrium import solve
from tests.figures import drawn

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
VALIDATION_PAGE = Path(__file__).resolve().parents[2] / "docs" / "validation.md"

#: The JSON keys `esba solve --json` promises.
SOLVE_KEYS = {"theta_deg", "total_angle_deg", "tip_mm", "pressure_mpa", "stable", "status", "effects", "segments", "variant", "solve_time_s"}


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys, *args: str) -> tuple[int, dict]:
    code, out, _ = run(capsys, *args, "--json")
    return code, json.loads(out)


def test_main_job_prints_and_writes_figure(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    saved = drawn.record_saved(monkeypatch)
    code, out, err = run(capsys, "solve")
    assert code == EXIT_OK, err
    assert "(-3.29, 7.17, 21.44) deg" in out
    assert "133.238, 10.217 mm" in out
    assert "stable" in out and "Solve_Succeeded" in out
    figure = tmp_path / DEFAULT_SOLVE_FIGURE
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {figure}" in out
    # what it shows: the loaded shape of the main job and the unloaded one, in the paper's frame
    (ax,) = saved[figure.resolve()].axes
    assert ax.get_xlabel() == "y (mm)" and ax.get_ylabel() == "x (mm), downwards"
    r = solve(MAIN_JOB)
    free = solve(MAIN_JOB.replace(payloads=tuple(p.scaled(0.0) for p in MAIN_JOB.payloads), gravity=False), pressure=r.pressure)
    loaded = drawn.labelled(ax, f"loaded: {r.total_angle_deg:.1f} deg")
    np.testing.assert_allclose(drawn.data(loaded), r.centreline[:, [1, 0]], rtol=1e-12, atol=1e-12)
    unloaded = drawn.labelled(ax, f"unloaded: {free.total_angle_deg:.1f} deg")
    np.testing.assert_allclose(drawn.data(unloaded), free.centreline[:, [1, 0]], rtol=1e-12, atol=1e-12)
    assert drawn.legend(ax) == [unloaded.get_label(), loaded.get_label()]


def test_main_job_json(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, d = run_json(capsys, "solve")
    assert code == EXIT_OK
    assert SOLVE_KEYS <= set(d)
    assert [round(t, 2) for t in d["theta_deg"]] == [-3.29, 7.17, 21.44]
    assert round(d["total_angle_deg"], 2) == 25.32
    assert [round(v, 2) for v in d["tip_mm"]] == [133.24, 10.22]
    assert d["pressure_mpa"] == pytest.approx(0.1238739, abs=5e-8)
    assert d["stable"] is True and d["status"] == "Solve_Succeeded"
    assert d["effects"] == ["air", "axial", "radial", "fibres", "payload"]
    assert d["segments"] == 3 and d["variant"] == "paper"
    assert d["figure"] == str(tmp_path / DEFAULT_SOLVE_FIGURE)


@pytest.mark.parametrize(
    "flags, check",
    [
        (["--segments", "4"], lambda d: d["segments"] == 4 and round(d["tip_mm"][1], 2) == 9.31),
        (["--pressure", "0.15"], lambda d: d["pressure_mpa"] == 0.15),
        (["--target-angle", "45"], lambda d: d["pressure_from"] == "target_angle_deg=45"),
        (["--no-payload"], lambda d: "payload" not in d["effects"] and abs(d["total_angle_deg"] - 90) < 1e-9),
        (["--payload", "0"], lambda d: "payload" in d["effects"] and abs(d["total_angle_deg"] - 90) < 1e-9),
        (["--gravity"], lambda d: "gravity" in d["effects"] and "gravity" in d["energy_terms_nmm"]),
        (["--no-fibres"], lambda d: "fibres" not in d["effects"]),
        (["--variant", "printed"], lambda d: d["variant"] == "printed"),
        (["--payload-angle", "0"], lambda d: d["payloads"] == [{"force_n": 2.0, "angle_deg": 0.0, "at": 1.0}]),
        (
            ["--payload", "1", "--payload", "0.5", "--payload-angle", "0", "--payload-angle", "90", "--payload-at", "0.5"],
            lambda d: d["payloads"] == [{"force_n": 1.0, "angle_deg": 0.0, "at": 0.5}, {"force_n": 0.5, "angle_deg": 90.0, "at": 0.5}]
            and d["effects"][-1] == "payload",
        ),
    ],
)
def test_flags_override_the_scene(capsys, flags, check):
    code, d = run_json(capsys, "solve", "--no-plot", *flags)
    assert code == EXIT_OK
    assert check(d), d


def test_scene_file_and_plot(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, d = run_json(capsys, "solve", str(EXAMPLES / "table2.toml"))
    assert code == EXIT_OK and "figure" not in d  # a scene file writes a figure only when asked
    assert not (tmp_path / DEFAULT_SOLVE_FIGURE).exists()
    assert [round(t, 2) for t in d["theta_deg"]] == [-3.29, 7.17, 21.44]
    (tmp_path / "sub").mkdir()
    plot = tmp_path / "sub" / "shape.png"
    code, d = run_json(capsys, "solve", str(EXAMPLES / "table2.toml"), "--segments", "2", "--plot", str(plot))
    assert code == EXIT_OK and plot.exists() and d["segments"] == 2 and d["figure"] == str(plot)


def test_failed_solve_exits_1(capsys):
    code, out, err = run(capsys, "solve", "--no-plot", "--max-iter", "1", "--no-continuation")
    assert code == EXIT_FAILED
    assert "NOT OK" in out and "Maximum_Iterations_Exceeded" in out
    assert err.startswith("esba: solve not ok: IPOPT did not converge")


def test_failed_solve_json_says_so(capsys):
    code, d = run_json(capsys, "solve", "--no-plot", "--max-iter", "1", "--no-continuation")
    assert code == EXIT_FAILED
    assert d["ok"] is False and d["status"] == "Maximum_Iterations_Exceeded" and d["message"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["solve", "--segments", "0"], "argument --segments/-n: segments=0: expected a whole number from 1 to 256"),
        (["solve", "--segments", "x"], "segments='x': expected a whole number from 1 to 256"),
        (["solve", "--pressure", "-1"], "pressure=-1: expected a pressure >= 0 MPa"),
        (["solve", "--pressure", "nan"], "pressure=nan: expected a finite number"),
        (["solve", "--pressure", "0.1", "--target-angle", "90"], "argument --target-angle: not allowed with argument --pressure"),
        (["solve", "--target-angle", "0"], "target_angle_deg=0: expected an angle > 0 degrees"),
        (["solve", "--payload", "abc"], "argument --payload: 'abc' is not a number"),
        (["solve", "--payload", "-2"], "payload.force=-2: expected a magnitude >= 0 N"),
        (["solve", "--payload-at", "1.5"], "payload.at=1.5: expected a fraction of the length with 0 < at <= 1"),
        (["solve", "--payload", "1", "--payload-angle", "0", "--payload-angle", "90"], "--payload-angle given 2 times for 1 payloads"),
        (["solve", "--no-payload", "--payload-angle", "0"], "--no-payload cannot be combined with --payload"),
        (["solve", "examples/none.toml"], "scene file 'examples/none.toml' does not exist"),
        (["solve", "--variant", "exact"], "argument --variant: invalid choice: 'exact'"),
        (["solve", "--max-iter", "0"], "argument --max-iter: max_iter=0: expected a whole number from 1 to 100000"),
        (["stiffness", "--payload", "0"], "forces=[0.0]: expected one or more payloads > 0 N"),
        (["pressure"], "pressure needs a target: --target-angle DEG"),
        (["pressure", "--target-angle", "-3"], "target_angle_deg=-3: expected an angle > 0 degrees"),
        (["pressure", "--pressure", "0.1", "--total-angle", "30"], "--pressure is what this command finds"),
        (["pressure", "--target-angle", "30", "--total-angle", "30"], "give one target"),
        (["pressure", "--total-angle", "30", "--no-payload"], "are targets under payloads: add --payload N"),
    ],
)
def test_usage_errors(capsys, args, message):
    code, out, err = run(capsys, *args)
    assert code == EXIT_USAGE
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("esba: error: ")
    assert message in lines[0]


def test_bad_scene_file_is_usage_error(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("segments = 3\n[actuator\n")
    code, out, err = run(capsys, "solve", str(bad))
    assert code == EXIT_USAGE
    assert err.strip() == f"esba: error: scene file '{bad}' is not valid TOML: Expected ']' at the end of a table declaration (at line 2, column 10)"


# ---------------------------------------------------------------------------------------------
# stiffness, pressure, validate


def test_stiffness_json(capsys):
    code, d = run_json(capsys, "stiffness")
    assert code == EXIT_OK
    assert d["payloads_n"] == [0.5, 1.0, 2.0] and len(d["stiffness_n_per_m"]) == 3
    assert d["pressure_mpa"] == pytest.approx(0.1238739, abs=5e-8)
    m = d["tangent"]["matrix_n_per_m"]
    assert len(m) == 2 and len(m[0]) == 2
    assert d["stiffness_n_per_m"][0] > d["stiffness_n_per_m"][2]


def test_stiffness_table_and_flags(capsys):
    code, out, _ = run(capsys, "stiffness", "--segments", "1", "--payload", "1")
    assert code == EXIT_OK
    assert "K_tip: singular" in out and "1.000" in out


def test_pressure_closed_form(capsys):
    code, d = run_json(capsys, "pressure", "--target-angle", "90")
    assert code == EXIT_OK and d["pressure_mpa"] == pytest.approx(0.1238739, abs=5e-8)
    assert d["method"].startswith("closed form")


def test_pressure_loaded_targets(capsys):
    code, d = run_json(capsys, "pressure", "--total-angle", "45")
    assert code == EXIT_OK and d["ok"] and d["equilibrium"]["total_angle_deg"] == pytest.approx(45.0, abs=1e-6)
    code, d = run_json(capsys, "pressure", "--tip-y", "50")
    assert code == EXIT_OK and d["equilibrium"]["tip_mm"][1] == pytest.approx(50.0, abs=1e-6)
    code, d = run_json(capsys, "pressure", "--tip-x", "100", "--tip-y", "50")
    assert code == EXIT_FAILED and not d["ok"] and "not reachable" in d["message"]


def test_validate_writes_and_checks(capsys, tmp_path):
    page = tmp_path / "validation.md"
    code, out, _ = run(capsys, "validate", "--out", str(page))
    assert code == EXIT_OK and page.exists() and "all within tolerance" in out
    assert "esba validate" in page.read_text()
    assert run(capsys, "validate", "--check", "--out", str(page))[0] == EXIT_OK
    page.write_text("stale\n")
    assert run(capsys, "validate", "--check", "--out", str(page))[0] == EXIT_FAILED


def test_committed_validation_page_is_fresh(capsys):
    code, _, err = run(capsys, "validate", "--check")
    assert code == EXIT_OK, f"{VALIDATION_PAGE} is stale: run `esba validate` and commit it ({err.strip()})"


def test_pressure_table_says_what_the_pressure_is_for(capsys):
    code, out, _ = run(capsys, "pressure", "--target-angle", "90")
    assert code == EXIT_OK
    assert "target: the pressure that bends the unloaded actuator to 90 deg in total (n = 3, paper)" in out
    assert "{" not in out  # no raw dict
    code, out, _ = run(capsys, "pressure", "--tip-y", "50")
    assert code == EXIT_OK and "target: the pressure that puts the loaded actuator's tip at y = 50 mm" in out


def test_monte_carlo_is_in_the_text_when_first_order_refuses_near_a_fold(capsys):
    """Issue 21: at F = 1.78 N, Omega = 122.2 deg first order refuses (next to a fold); the Monte Carlo
    still ran, and its result was only in --json. The text shows it, and says there is no agreement to judge."""
    args = ["solve", "--payload", "1.78", "--payload-angle", "122.2", "--sigma", "E=0.01", "--monte-carlo", "50", "--no-plot"]
    code, out, err = run(capsys, *args)
    assert code == EXIT_OK, err
    assert "uncertainty: near_fold:" in out
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("Monte Carlo:"))
    code, d = run_json(capsys, *args)
    std = d["monte_carlo"]["std"]
    assert d["uncertainty"]["std_total_angle_deg"] is None and std["total_angle"] > 0
    assert f"std total angle {std['total_angle']:.4g} deg" in line and "50 samples" in line
    assert "agreement: none to judge: first order gives no answer (near_fold" in out


def test_stiffness_says_where_its_tangent_is_taken_and_why_k_tip_differs(capsys):
    """Issue 21: "tangent at F = 0: horizontal 55.76 N/m" beside K_tip's yy entry 677.5, without saying at
    which state K_tip is or why the two differ. Both are the unloaded state's; the directional value is
    1 / (u^T C u) with C = K_tip^-1 (the tip free across the force), K_tip's entry holds it still."""
    code, d = run_json(capsys, "stiffness")
    assert code == EXIT_OK
    t = d["tangent"]
    c = np.linalg.inv(np.array(t["matrix_n_per_m"]))
    assert t["horizontal_n_per_m"] == pytest.approx(1.0 / c[1, 1], rel=1e-9) and t["matrix_n_per_m"][1][1] > 10 * t["horizontal_n_per_m"]
    assert t["state"].startswith("the unloaded state (F = 0)")
    code, out, _ = run(capsys, "stiffness")
    assert f"tangent stiffness of the unloaded state (F = 0, {d['initial_angle_deg']:.2f} deg)" in out
    assert f"the tip free to move across it, 1 / (u^T C u) (the limit of K as F -> 0): horizontal {t['horizontal_n_per_m']:.3f} N/m" in out
    assert "K_tip = C^-1 (N/m, x down, y horizontal)" in out and "holds the tip still in the other direction" in out
