"""The 3-D Monte Carlo as a study (esba.studies.monte_carlo): one CSV and its study.json, resumed,
in this process and on Dask, the same samples every way; and `esba solve --3d --monte-carlo`."""

from __future__ import annotations

import csv
import importlib.util
import io
import json

import numpy as np
import pytest

from esba.calibration.sigmas import parse_sigma, resolve_sigmas
from esba.calibration.uncertainty import MonteCarloOptions
from esba.calibration.uncertainty3d import monte_carlo3d as monte_carlo3d_here
from esba.cli import main
from esba.model.scene import Payload, Scene
from esba.statics.spatial import check_section
from esba.studies.chunks import StudyError, sidecar
from esba.studies.distributed import SerialRunner
from esba.studies.monte_carlo import monte_carlo3d, monte_carlo_study
from tests.studies.runners import StopAfter

pytestmark = pytest.mark.timeout(600)
needs_dask = pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="dask.distributed is not installed")

SCENE = Scene(pressure=0.12, payloads=(Payload(0.6, 90.0, 1.0, 20.0),))
SECTION = check_section({"EI_side": 4e5, "GJ": 1e5}, SCENE)
SIGMAS = resolve_sigmas(SCENE, [parse_sigma("GJ=20%"), parse_sigma("Beta1=±5"), parse_sigma("E=5%")], SECTION)
OPTIONS = MonteCarloOptions(samples=36, seed=2, chunk=10)
FIELDS = ("samples", "code", "q", "tip", "theta", "total_angle")


@pytest.fixture(scope="module")
def whole():
    return monte_carlo3d_here(SCENE, SIGMAS, OPTIONS, section=SECTION)


def _same(a, b):
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.to_dict() == b.to_dict()


def _stream_interrupt_resume(tmp_path, runner, whole):
    out = tmp_path / "mc3d.csv"
    with pytest.raises(KeyboardInterrupt):
        monte_carlo_study(SCENE, SIGMAS, OPTIONS, runner=StopAfter(SerialRunner(), 2), out=out, three_d=True, section=SECTION)
    mc, info = monte_carlo_study(SCENE, SIGMAS, OPTIONS, runner=runner, out=out, resume=True, three_d=True, section=SECTION)
    assert info["resumed_from_sample"] == 20
    _same(mc, whole)
    rows = list(csv.DictReader(io.StringIO(out.read_text(encoding="utf-8"))))
    assert [int(r["sample"]) for r in rows] == list(range(36)) and {r["outcome"] for r in rows} == {"ok"}
    assert [float(r["tip_z_mm"]) for r in rows] == whole.tip[:, 2].tolist() and [float(r["tau3_rad"]) for r in rows] == whole.q[:, 8].tolist()
    meta = json.loads(sidecar(out).read_text(encoding="utf-8"))
    assert meta["kind"] == "monte-carlo-3d" and meta["identity"]["section"] == SECTION and meta["rows"] == 36
    return out


def test_a_3d_monte_carlo_study_streams_its_samples_and_resumes_to_the_same_numbers(tmp_path, whole):
    out = _stream_interrupt_resume(tmp_path, SerialRunner(), whole)
    again, info = monte_carlo_study(SCENE, SIGMAS, OPTIONS, out=out, resume=True, three_d=True, section=SECTION)  # nothing left to solve
    assert info["resumed_from_sample"] == 36
    _same(again, whole)
    with pytest.raises(StudyError, match="belongs to another study"):
        monte_carlo_study(SCENE, SIGMAS, OPTIONS, out=out, resume=True, three_d=True, section={**SECTION, "GJ": 2e5})
    with pytest.raises(StudyError, match="holds a 'monte-carlo-3d' study, not a 'monte-carlo' one"):
        monte_carlo_study(SCENE.replace(payloads=(Payload(0.6, 90.0),)), resolve_sigmas(SCENE, [parse_sigma("E=5%")]), OPTIONS, out=out, resume=True)


@needs_dask
def test_a_3d_monte_carlo_on_two_dask_workers_is_the_local_one_and_resumes_there(tmp_path, whole):
    from esba.studies.distributed import open_runner

    with open_runner(workers=2) as runner:
        _same(monte_carlo3d(SCENE, SIGMAS, OPTIONS, runner=runner, section=SECTION), whole)
        _stream_interrupt_resume(tmp_path, runner, whole)


def _one_line(capsys, argv, needle):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("esba: error:") and needle in err, err


BASE_ARGV = ["solve", "--3d", "--pressure", "0.12", "--payload", "0.6", "--payload-out-of-plane", "20", "--section", "EI_side=4e5",
             "--section", "GJ=1e5", "--no-plot"]


def test_cli_3d_monte_carlo_json_is_the_api_and_the_same_with_a_sample_file(capsys, tmp_path):
    argv = [*BASE_ARGV, "--sigma", "GJ=20%", "--sigma", "Beta1=±5", "--sigma", "E=5%", "--monte-carlo", "36", "--seed", "2", "--mc-chunk", "10", "--json"]
    assert main(argv) == 0
    d = json.loads(capsys.readouterr().out)
    api = monte_carlo3d_here(SCENE, SIGMAS, OPTIONS, section=SECTION)
    assert d["monte_carlo"]["std"] == api.to_dict()["std"] and d["monte_carlo"]["counts"]["ok"] == 36
    assert d["uncertainty"]["model"] == "3d" and d["uncertainty"]["status"] == "ok" and set(d["agreement"]) == {"agree", "verdict", "outputs"}
    out = tmp_path / "mc.csv"
    assert main([*argv, "--mc-out", str(out)]) == 0
    streamed = json.loads(capsys.readouterr().out)
    assert streamed["monte_carlo"]["std"] == d["monte_carlo"]["std"] and streamed["monte_carlo"]["study"]["out"] == str(out)
    text = out.read_text(encoding="utf-8")
    out.write_text("".join(text.splitlines(keepends=True)[:15]), encoding="utf-8")
    assert main([*argv, "--mc-out", str(out), "--resume"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    assert resumed["monte_carlo"]["study"]["resumed_from_sample"] == 14 and resumed["monte_carlo"]["std"] == d["monte_carlo"]["std"]
    assert out.read_text(encoding="utf-8") == text


def test_cli_3d_text_has_the_sideways_statistics_and_sensitivities(capsys):
    assert main([*BASE_ARGV, "--sigma", "GJ=10%", "--monte-carlo", "10", "--sensitivities"]) == 0
    text = capsys.readouterr().out
    assert "first order: std tip x, y, z" in text and "twist" in text and "Monte Carlo: 10 samples (seed 0)" in text
    assert "Beta1: tip_x" in text and "d/dp: ok" in text


@pytest.mark.parametrize("extra, needle", [
    (["--sigma", "Beta2=1"], "'Beta2' is not a parameter of this 3-D scene"),
    (["--sigma", "GJ=-1"], "SIGMA > 0"),
    (["--monte-carlo", "20"], "--monte-carlo needs uncertain parameters"),
    (["--sigma", "GJ=10%", "--resume"], "--workers, --scheduler, --mc-out and --resume run the Monte Carlo"),
    (["--sigma", "GJ=10%", "--monte-carlo", "20", "--resume"], "--resume continues the Monte Carlo in its sample file"),
    (["--sigma", "GJ=10%", "--seed", "3"], "--seed"),
    (["--sigma", "GJ=10%", "--history", "together"], "--history"),
    (["--sigma", "GJ=10%", "--monte-carlo", "100001"], "--monte-carlo: samples=100001: at most 100000 in 3-D"),
])
def test_cli_bad_3d_uncertainty_input_is_one_line_exit_2(capsys, extra, needle):
    _one_line(capsys, [*BASE_ARGV, *extra], needle)


def test_cli_a_relative_sigma_of_an_in_plane_payloads_beta_is_one_line_exit_2(capsys):
    _one_line(capsys, ["solve", "--3d", "--pressure", "0.12", "--payload", "0.6", "--sigma", "Beta1=5%", "--no-plot"], "Beta1 is 0 in this scene")
