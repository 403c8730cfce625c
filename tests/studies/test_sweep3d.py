"""3-D sweeps (esba.studies.sweep3d): the 3-D model over a grid, in this process and on Dask, one CSV with its study.json."""

from __future__ import annotations

import csv
import importlib.util
import json

import numpy as np
import pytest

from esba.model.scene import Payload, Scene
from esba.statics.equilibrium import solve
from esba.statics.spatial import solve_scene3d
from esba.studies.chunks import sidecar
from esba.studies.sweep3d import Sweep3DError, plan_sweep3d, sweep3d_study
from tests.studies.runners import StopAfter

SECTION = {"EI_side": 4e5, "GJ": 1e5}
BASE = Scene(pressure=0.12, payloads=(Payload(0.6, 90.0),))
GRID = {"payload_out_of_plane": [0.0, 40.0], "GJ": [2e4, 1e5]}

needs_dask = pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="dask.distributed is not installed")


@pytest.fixture(scope="module")
def local():
    return sweep3d_study(plan_sweep3d(BASE, SECTION, **GRID), chunk=3)


def test_each_row_is_the_3d_solve_of_its_scene_and_in_plane_rows_are_planar(local):
    assert [(r["payload_out_of_plane_deg"], r["GJ_nmm2"]) for r in local.rows] == [(0.0, 2e4), (0.0, 1e5), (40.0, 2e4), (40.0, 1e5)]
    assert local.counts == {"ok": 4} and local.chunks == 2
    planar = solve(BASE)
    for r in local.rows:
        beta, gj = r["payload_out_of_plane_deg"], r["GJ_nmm2"]
        eq = solve_scene3d(BASE.replace(payloads=(Payload(0.6, 90.0, 1.0, beta),)), {"EI_side": 4e5, "GJ": gj})
        assert np.allclose([r[f"theta{i}_deg"] for i in (1, 2, 3)], np.degrees(eq.theta), atol=1e-9, rtol=0)
        assert r["tip_z_mm"] == pytest.approx(eq.tip[2], abs=1e-9)
        if beta == 0.0:  # in the plane: the planar solve, no sideways bend or twist
            assert np.abs(np.array([r[f"theta{i}_deg"] for i in (1, 2, 3)]) - planar.theta_deg).max() <= 1e-10
            assert all(r[f"{c}{i}_deg"] == 0.0 for c in ("psi", "tau") for i in (1, 2, 3)) and r["tip_z_mm"] == 0.0
    # a softer torsion lets the same out-of-plane load twist the actuator more
    twist = {r["GJ_nmm2"]: abs(r["total_twist_deg"]) for r in local.rows if r["payload_out_of_plane_deg"] == 40.0}
    assert twist[2e4] > twist[1e5] > 0


def test_a_3d_study_is_one_csv_with_its_study_json(tmp_path, local):
    out = tmp_path / "grid3d.csv"
    study = sweep3d_study(plan_sweep3d(BASE, SECTION, **GRID), chunk=2, out=out)
    meta = json.loads(sidecar(out).read_text(encoding="utf-8"))
    assert meta["kind"] == "sweep3d" and meta["hash"] == study.hash and meta["identity"]["model"] == "3d"
    lines = [ln for ln in out.read_text(encoding="utf-8").splitlines() if not ln.startswith("#")]
    rows = list(csv.DictReader(lines))
    assert len(rows) == 4 and [r["status"] for r in rows] == ["ok"] * 4
    for got, ref in zip(rows, local.rows):
        assert float(got["tip_z_mm"]) == ref["tip_z_mm"] and float(got["tau3_deg"]) == ref["tau3_deg"]


@needs_dask
@pytest.mark.timeout(300)
def test_a_3d_sweep_on_two_dask_workers_is_the_local_one(local):
    from esba.studies.distributed import open_runner

    with open_runner(workers=2) as runner:
        study = sweep3d_study(plan_sweep3d(BASE, SECTION, **GRID), runner=runner, chunk=1)
    assert "2 worker processes" in study.runner and study.chunks == 4
    assert study.rows == local.rows  # row for row, value for value


@pytest.mark.parametrize("axes, match", [
    ({"payload_out_of_plane": [120.0]}, "-90 to 90"),
    ({"GJ": [0.0]}, "stiffness > 0"),
    ({"GJ": [float("nan")]}, "finite"),
    ({"r2": [-1.0]}, "r2"),
    ({"twist": [1.0]}, "axis 'twist'"),
])
def test_bad_axes_are_refused_in_one_line(axes, match):
    with pytest.raises(Sweep3DError, match=match):
        plan_sweep3d(BASE, SECTION, **axes)


def test_cli_3d_sweep_writes_one_csv_and_refuses_bad_flags(tmp_path, capsys):
    from esba.cli import main

    out = tmp_path / "s.csv"
    assert main(["sweep", "--pressure", "0.12", "--payload", "0.6", "--payload-out-of-plane", "0,40", "--section", "EI_side=4e5",
                 "--section", "GJ=1e5", "--out", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["counts"] == {"ok": 2} and d["out"] == str(out) and sidecar(out).exists()
    for argv, match in ((["--3d", "--pressure", "0.1", "--payload-out-of-plane", "100"], "-90 to 90"),
                        (["--3d", "--pressure", "0.1", "--GJ", "-1"], "stiffness > 0"),
                        (["--3d", "--target-angle", "90"], "--target-angle is not used"),
                        (["--3d", "--pressure", "0.1", "--section", "GJ=x"], "--section"),
                        (["--3d", "--pressure", "0.1", "--out", str(tmp_path / "s.json")], "--out")):
        assert main(["sweep", *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and match in err, err


# ---------------------------------------------------------------------------------------------
# resuming a 3-D study, and the 3-D Monte Carlo as a study file


def _interrupted_then_resumed(tmp_path, runner):
    from esba.studies.distributed import SerialRunner

    plan = plan_sweep3d(BASE, SECTION, **GRID)
    whole = tmp_path / "whole.csv"
    sweep3d_study(plan, chunk=3, out=whole)
    out = tmp_path / "cut.csv"
    with pytest.raises(KeyboardInterrupt):
        sweep3d_study(plan, runner=StopAfter(SerialRunner(), 1), chunk=1, out=out)
    text = out.read_text(encoding="utf-8")
    assert len(text.splitlines()) == 2  # the column names and one row
    out.write_text(text + whole.read_text(encoding="utf-8").splitlines(keepends=True)[2][:30], encoding="utf-8")  # a row cut short
    again = sweep3d_study(plan, runner=runner, chunk=2, out=out, resume=True)
    assert again.resumed_from == 1 and again.counts == {"ok": 4} and again.chunks == 2
    assert out.read_bytes() == whole.read_bytes()  # byte for byte the uninterrupted study
    assert sidecar(out).read_text(encoding="utf-8") == sidecar(whole).read_text(encoding="utf-8")
    return plan, out


def test_an_interrupted_3d_study_resumes_from_its_file(tmp_path):
    from esba.studies.distributed import SerialRunner

    _interrupted_then_resumed(tmp_path, SerialRunner())


@needs_dask
@pytest.mark.timeout(300)
def test_an_interrupted_3d_study_resumes_on_two_dask_workers(tmp_path):
    from esba.studies.distributed import open_runner

    with open_runner(workers=2) as runner:
        _interrupted_then_resumed(tmp_path, runner)


def test_resume_refuses_another_3d_study_and_an_edited_row(tmp_path):
    from esba.studies.chunks import StudyError

    plan, out = _interrupted_then_resumed(tmp_path, None)
    with pytest.raises(StudyError, match="belongs to another study .* it differs in axes.GJ"):
        sweep3d_study(plan_sweep3d(BASE, SECTION, payload_out_of_plane=[0.0, 40.0], GJ=[3e4, 1e5]), out=out, resume=True)
    text = out.read_text(encoding="utf-8").splitlines(keepends=True)
    text[2] = text[2].replace(",100000.0,", ",100001.0,", 1)
    edited = "".join(text)
    out.write_text(edited, encoding="utf-8")
    with pytest.raises(StudyError, match=r"row 2 has GJ_nmm2=100001.0 where the plan has 100000.0"):
        sweep3d_study(plan, out=out, resume=True)
    assert out.read_text(encoding="utf-8") == edited  # left as it was found, not rewritten


def test_cli_3d_sweep_resumes_and_refuses_resume_without_out(tmp_path, capsys):
    from esba.cli import main

    out = tmp_path / "s.csv"
    argv = ["sweep", "--pressure", "0.12", "--payload", "0.6", "--payload-out-of-plane", "0,40", "--section", "EI_side=4e5", "--GJ", "1e5", "--out", str(out)]
    assert main(argv) == 0
    whole = out.read_bytes()
    out.write_bytes(b"".join(whole.splitlines(keepends=True)[:2]))
    capsys.readouterr()
    assert main([*argv, "--resume", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["resumed_from_row"] == 1 and d["counts"] == {"ok": 2} and out.read_bytes() == whole
    assert main(["sweep", "--3d", "--pressure", "0.1", "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--resume continues a 3-D study from the CSV file it streams to: give --out FILE.csv" in err
