"""Uncertainty (esba.calibration.uncertainty): sigma specs, first-order propagation, Monte Carlo on the batch path
(agreement at small sigma, a poor case near a fold, chunking), and the command line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from esba.analysis.sensitivity import sensitivities
from esba.calibration.uncertainty import (
    MonteCarloOptions,
    UncertaintyError,
    compare,
    draw_samples,
    ellipse,
    load_sigmas,
    monte_carlo,
    parse_sigma,
    propagate,
    resolve_sigmas,
)
from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.model.scene import MAIN_JOB, Payload, Scene, load_scene
from esba.statics.equilibrium import solve
from tests.figures import drawn
from tests.tolerances import MC_AGREE_REL

#: Just below the buckling load of a nearly straight actuator pushed along its axis (about 2.9 N).
NEAR_FOLD = Scene(pressure=1e-3, payloads=(Payload(2.7, 180.0),))


def _no_nan(text: str) -> dict:
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))


@pytest.fixture(scope="module")
def main_job():
    return solve(MAIN_JOB)


# ---------------------------------------------------------------------------------------------
# specs


@pytest.mark.parametrize(
    "text, value, relative, dist",
    [("E=0.05", 0.05, False, "normal"), ("E=10%", 0.1, True, "normal"), ("r2=±0.1", 0.1, False, "uniform"),
     ("r2=+-0.1", 0.1, False, "uniform"), ("rho = ±5 %", 0.05, True, "uniform")],
)
def test_parse_sigma(text, value, relative, dist):
    s = parse_sigma(text)
    assert (s.value, s.relative, s.distribution) == (pytest.approx(value), relative, dist)


@pytest.mark.parametrize("text", ["E", "E=", "=0.1", "E=0", "E=-0.1", "E=nan", "E=inf", "E=abc", "E=1=2", "E=±"])
def test_bad_sigma_names_it(text):
    with pytest.raises(UncertaintyError, match="--sigma"):
        parse_sigma(text)


def test_resolve_makes_sigmas_absolute():
    s = resolve_sigmas(MAIN_JOB, [parse_sigma("E=10%"), parse_sigma("r2=±0.3"), parse_sigma("E=0.02")])
    by = {x.name: x for x in s}
    assert by["E"].sigma == 0.02 and by["E"].distribution == "normal"  # the later spec wins
    assert by["r2"].sigma == pytest.approx(0.3 / math.sqrt(3.0)) and by["r2"].half_width == 0.3
    assert [x.name for x in s] == ["r2", "E"]  # the scene's parameter order


def test_resolve_refuses_what_the_scene_does_not_have():
    with pytest.raises(UncertaintyError, match="'P' is not a parameter of this scene .*target_angle"):
        resolve_sigmas(MAIN_JOB, [parse_sigma("P=0.01")])
    with pytest.raises(UncertaintyError, match="'M' is not a parameter"):
        resolve_sigmas(MAIN_JOB, [parse_sigma("M=0.001")])
    with pytest.raises(UncertaintyError, match="relative sigma is 0"):
        resolve_sigmas(MAIN_JOB.replace(d=0.0), [parse_sigma("d=5%")])


def test_scene_file_uncertainty_table(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('segments = 3\n[loads]\npressure = 0.12\n[uncertainty]\nE = "10%"\nr2 = 0.1\nrho = "±2"\n', encoding="utf-8")
    scene = load_scene(path)  # the scene reader accepts the table
    s = resolve_sigmas(scene, load_sigmas(path))
    assert [(x.name, round(x.sigma, 6)) for x in s] == [("r2", 0.1), ("rho", round(2 / math.sqrt(3), 6)), ("E", 0.054)]
    path.write_text("[uncertainty]\nE = true\n", encoding="utf-8")
    with pytest.raises(UncertaintyError, match=r"\[uncertainty\] 'E=True'"):
        load_sigmas(path)
    with pytest.raises(UncertaintyError, match="does not exist"):
        load_sigmas(tmp_path / "missing.toml")


# ---------------------------------------------------------------------------------------------
# first order


def test_first_order_is_the_sensitivities_times_sigma(main_job):
    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=0.05"), parse_sigma("F1=0.1")])
    u = propagate(main_job, sig)
    s = sensitivities(main_job, ["E", "F1"])
    expected = math.degrees(math.hypot(s.dtotal[0] * 0.05, s.dtotal[1] * 0.1))
    assert u.ok and u.std_total_angle_deg == pytest.approx(expected, rel=1e-12)
    assert u.std_tip_mm[1] == pytest.approx(math.hypot(s.dtip[1, 0] * 0.05, s.dtip[1, 1] * 0.1), rel=1e-12)
    assert sum(u.shares["total_angle"].values()) == pytest.approx(1.0)
    axes, angle = u.ellipse(0.95)
    assert axes[0] >= axes[1] >= 0 and 0 <= angle < math.pi
    # the 95 % ellipse's semi-axes are sqrt(chi2_2(0.95) * eigenvalues of C)
    assert axes[0] ** 2 == pytest.approx(-2 * math.log(0.05) * np.linalg.eigvalsh(u.cov_tip)[-1], rel=1e-12)
    json.dumps(u.to_dict(), allow_nan=False)


def test_ellipse_rejects_a_bad_level():
    with pytest.raises(UncertaintyError, match="level"):
        ellipse(np.eye(2), 1.0)


# ---------------------------------------------------------------------------------------------
# Monte Carlo


def test_first_order_agrees_with_monte_carlo_at_small_sigma(main_job):
    """10 000 samples on the batch path, E and r2 at 1 % (normal and a tolerance), the payload at 0.02 N."""
    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=1%"), parse_sigma("r2=±1%"), parse_sigma("F1=0.02")])
    u = propagate(main_job, sig)
    mc = monte_carlo(MAIN_JOB, sig, MonteCarloOptions(samples=10_000, seed=1))
    a = compare(u, mc)
    assert mc.counts == {"samples": 10_000, "ok": 10_000, "invalid": 0, "not_ok": 0}
    assert a.agree, a.verdict
    for row in a.rows:
        assert row["std_ratio"] == pytest.approx(1.0, abs=MC_AGREE_REL), row
        assert abs(row["mean_shift_sigmas"]) < 0.1, row
    assert "agree" in a.verdict
    json.dumps(a.to_dict(), allow_nan=False)
    json.dumps(mc.to_dict(), allow_nan=False)


def test_first_order_is_poor_near_a_fold_and_says_so():
    """sigma(F) = 0.1 N at 2.7 N, 0.2 N below the buckling load: samples beyond it snap."""
    r = solve(NEAR_FOLD)
    sig = resolve_sigmas(NEAR_FOLD, [parse_sigma("F1=0.1")])
    u = propagate(r, sig)
    assert u.status == "beyond_linear_range" and "reaches the fold" in u.message
    mc = monte_carlo(NEAR_FOLD, sig, MonteCarloOptions(samples=1000, seed=0))
    a = compare(u, mc)
    assert not a.agree and a.verdict.startswith("first order is poor here")
    ratio = {row["output"]: row["std_ratio"] for row in a.rows}
    assert ratio["total_angle"] > 3.0  # the snapped samples spread far beyond the linear estimate


def test_at_a_fold_there_is_no_first_order_answer():
    from esba.analysis.sensitivity import SensitivityOptions

    r = solve(Scene(pressure=1e-3, payloads=(Payload(2.9, 180.0),)))
    u = propagate(r, resolve_sigmas(r.scene, [parse_sigma("F1=0.01")]), SensitivityOptions(fold_tol=0.02))
    assert u.status == "near_fold" and not u.has_numbers
    d = u.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["std_tip_mm"] is None and "fold" in d["message"]


def test_monte_carlo_is_the_same_whatever_the_chunking():
    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=5%"), parse_sigma("Omega1=±3")])
    opts = MonteCarloOptions(samples=300, seed=7)
    one = monte_carlo(MAIN_JOB, sig, opts, chunks=[300])
    three = monte_carlo(MAIN_JOB, sig, opts, chunks=[17, 200, 83])
    for field in ("samples", "code", "theta", "tip", "total_angle"):
        np.testing.assert_array_equal(getattr(one, field), getattr(three, field))
    # the samples are drawn up front from the seed alone
    np.testing.assert_array_equal(one.samples, draw_samples(sig, 300, 7))
    with pytest.raises(UncertaintyError, match="add up"):
        monte_carlo(MAIN_JOB, sig, opts, chunks=[100, 100])


def test_samples_outside_the_scene_are_counted_not_solved():
    """A tolerance on a tip payload's point: half the samples would lie beyond the tip."""
    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("s1=±0.01")])
    mc = monte_carlo(MAIN_JOB, sig, MonteCarloOptions(samples=200, seed=0))
    c = mc.counts
    assert c["invalid"] == int(np.sum(mc.samples[0] > 1.0)) and 60 < c["invalid"] < 140
    assert c["ok"] + c["invalid"] == 200
    assert np.all(np.isnan(mc.tip[mc.code == 1]))
    a = compare(propagate(solve(MAIN_JOB), sig), mc)
    assert "outside the scene's rules" in a.verdict


def test_sigmas_must_belong_to_the_scene():
    sig = resolve_sigmas(NEAR_FOLD, [parse_sigma("P=1e-4")])
    with pytest.raises(UncertaintyError, match="'P' is not a parameter of this scene"):
        monte_carlo(MAIN_JOB, sig, MonteCarloOptions(samples=10))
    with pytest.raises(UncertaintyError, match="'P' is not a parameter of this scene"):
        propagate(solve(MAIN_JOB), sig)
    with pytest.raises(UncertaintyError, match="expected Sigma"):
        propagate(solve(MAIN_JOB), ["E=0.1"])
    with pytest.raises(UncertaintyError, match="at least one"):
        monte_carlo(MAIN_JOB, [])


def test_monte_carlo_options_are_checked():
    with pytest.raises(UncertaintyError, match="seed=-1"):
        MonteCarloOptions(seed=-1)
    with pytest.raises(UncertaintyError, match="agree_rel"):
        MonteCarloOptions(agree_rel=2.0)


# ---------------------------------------------------------------------------------------------
# command line


def test_cli_sigma_and_monte_carlo(capsys, tmp_path, monkeypatch):
    saved = drawn.record_saved(monkeypatch)
    fig = tmp_path / "u.png"
    code = main(["solve", "--sigma", "E=0.05", "--sigma", "r2=±0.1", "--monte-carlo", "500", "--plot", str(fig), "--json"])
    d = _no_nan(capsys.readouterr().out)
    assert code == EXIT_OK
    assert d["uncertainty"]["status"] == "ok" and len(d["uncertainty"]["std_tip_mm"]) == 2
    assert d["uncertainty"]["tip_ellipse_95"]["semi_axes_mm"][0] > 0
    assert d["monte_carlo"]["counts"]["ok"] == 500 and d["monte_carlo"]["seed"] == 0
    assert isinstance(d["agreement"]["agree"], bool)
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the figure: the shapes, the Monte Carlo tips and the first-order 95 % ellipse around the tip
    (ax,) = saved[fig.resolve()].axes
    tips = drawn.labelled(ax, "Monte Carlo tips (500)")
    assert len(drawn.xy(tips)[0]) == 500
    ellipse = drawn.data(drawn.labelled(ax, "tip, 95 % ellipse (first order)"))
    x, y = d["tip_mm"]
    centre = ellipse[:-1].mean(axis=0)  # the closed curve's points, the repeated end left out
    assert centre == pytest.approx([y, x], abs=1e-6)  # drawn in the paper's frame: y across, x down
    half = d["uncertainty"]["tip_ellipse_95"]["semi_axes_mm"]
    radius = np.linalg.norm(ellipse - centre, axis=1)
    assert radius.max() == pytest.approx(max(half), rel=1e-3) and radius.min() == pytest.approx(min(half), rel=1e-3)


def test_cli_scene_file_sigmas_and_table(capsys, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[[payloads]]\nforce = 2.0\n[uncertainty]\nE = "20%"\n', encoding="utf-8")
    assert main(["solve", str(path), "--sigma", "F1=0.1"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "first order" in out and "E 0.108 MPa" in out and "F1 0.1 N" in out


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--sigma", "E=-1"], "--sigma 'E=-1'"),
        (["--sigma", "Q=1"], "sigma of 'Q' is not a parameter"),
        (["--sigma", "P=0.01"], "use target_angle"),
        (["--monte-carlo", "1000"], "--monte-carlo needs uncertain parameters"),
        (["--sigma", "E=1", "--monte-carlo", "3"], "samples >= 10"),
        (["--sigma", "E=1", "--monte-carlo", "100", "--seed", "-2"], "--seed"),
        (["--sigma", "E=1", "--monte-carlo", "2000000"], "at most 1000000"),
    ],
)
def test_cli_bad_uncertainty_input_is_one_line_exit_2(capsys, argv, needle):
    assert main(["solve", "--no-plot", *argv]) == EXIT_USAGE
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and needle in err and err.startswith("esba: error:")


def test_a_monte_carlo_with_no_sample_solved_compares_nothing(capsys, tmp_path, monkeypatch):
    """Every sample outside the scene's rules: no NaN verdict, a plain 'no comparison' and a warning."""
    monkeypatch.chdir(tmp_path)
    assert main(["solve", "--sigma", "r2=±100", "--monte-carlo", "10", "--no-plot", "--json"]) == EXIT_OK
    out, err = capsys.readouterr()
    data = json.loads(out)
    assert data["monte_carlo"]["counts"]["ok"] == 0
    verdict = data["agreement"]["verdict"]
    assert verdict.startswith("no comparison: 0 of 10 Monte Carlo samples solved") and "nan" not in verdict
    assert data["agreement"]["agree"] is False
    assert f"esba: warning: {verdict}" in err
