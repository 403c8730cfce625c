"""Grid sweeps (esba.studies.sweep) and the ``esba sweep`` command."""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest

from esba.cli import main
from esba.figures.sweeps import FIG12_D, FIG12_R2, fig12, sweep_figure
from esba.model.scene import Actuator, Payload, Scene
from esba.statics.batch import BatchOptions
from esba.statics.equilibrium import pressure_for_angle, solve
from esba.studies.sweep import AXES, SweepError, parse_values, sweep
from tests.figures import drawn
from tests.tolerances import BATCH_THETA_ATOL

INTERPRETED = BatchOptions(compile="never")


def test_grid_order_and_agreement_with_solve():
    base = Scene(payloads=(Payload(1.0, 60.0, 0.8),))
    s = sweep(base, pressure=[0.05, 0.15], payload=[0.0, 1.0, 2.0], options=INTERPRETED)
    assert s.shape == (2, 3) and s.ok.all()
    grid_p = s.grid(s.points["pressure"])
    grid_f = s.grid(s.points["payload"])
    assert grid_p[1, 0] == 0.15 and grid_f[1, 2] == 2.0  # C order over the axes in AXES order
    for i in (0, 4, 5):
        p, f = s.points["pressure"][i], s.points["payload"][i]
        ref = solve(base.replace(pressure=p, payloads=(Payload(f, 60.0, 0.8),)))
        np.testing.assert_allclose(s.theta[i], ref.theta, atol=BATCH_THETA_ATOL)
        assert s.points["payload_angle"][i] == 60.0


def test_geometry_grid_marks_infeasible_points_and_finds_each_pressure():
    s = sweep(Scene(target_angle_deg=90.0), r2=[2.0, 4.0, 6.0], d=[0.0, 3.0], options=INTERPRETED)
    assert s.status.tolist() == ["ok", "ok", "ok", "ok", "ok", "infeasible"]
    assert "r2 + d < r1" in s.messages[5] and math.isnan(s.total_angle_deg[5])
    # each design at its own 90 degree pressure (closed form), as a scene with a target angle
    np.testing.assert_allclose(s.total_angle_deg[:5], 90.0, atol=1e-8)
    for i in range(5):
        act = Actuator(r2=s.points["r2"][i], d=s.points["d"][i])
        assert s.pressure[i] == pytest.approx(pressure_for_angle(Scene(actuator=act), 90.0), rel=1e-10)


def test_payload_direction_axis():
    s = sweep(Scene(target_angle_deg=90.0), payload=2.0, payload_angle=[0.0, 90.0, 180.0, 270.0], options=INTERPRETED)
    assert s.ok.all()
    ref = solve(Scene(target_angle_deg=90.0, payloads=(Payload(2.0, 90.0),)))
    np.testing.assert_allclose(s.theta[1], ref.theta, atol=BATCH_THETA_ATOL)


def test_rows_csv_and_json(tmp_path):
    s = sweep(Scene(pressure=0.1), r2=[3.0, 5.0], d=[2.0, 4.0], options=INTERPRETED)
    rows = list(csv.DictReader(io.StringIO(s.to_csv())))
    assert len(rows) == 4 and rows[3]["status"] == "infeasible" and rows[3]["total_angle_deg"] == ""
    assert {"pressure_mpa", "payload_n", "r2_mm", "d_mm", "theta3_deg", "tip_y_mm", "message"} <= set(rows[0])
    assert float(rows[0]["total_angle_deg"]) == pytest.approx(s.total_angle_deg[0])
    out = s.write(tmp_path / "grid.json")
    data = json.loads(out.read_text())
    assert data["counts"] == {"ok": 3, "not ok": 0, "infeasible": 1}
    assert data["axes"]["r2"] == {"values": [3.0, 5.0], "unit": "mm"}
    with pytest.raises(SweepError, match=r"\.csv or \.json"):
        s.write(tmp_path / "grid.txt")


def test_bad_sweeps_are_refused():
    with pytest.raises(SweepError, match="at least one axis"):
        sweep(Scene())
    with pytest.raises(SweepError, match="pressure: -0.1 MPa"):
        sweep(Scene(), pressure=[-0.1, 0.1])
    with pytest.raises(SweepError, match="r2: 0 mm"):
        sweep(Scene(), r2=[0.0])
    assert parse_values("0:1:3") == [0.0, 0.5, 1.0] and parse_values("7") == [7.0]
    with pytest.raises(SweepError):
        parse_values("a,b")
    assert list(AXES) == ["pressure", "payload", "payload_angle", "L", "r1", "r2", "d", "rho_deg", "E", "M"]


def test_fig12_trends_are_the_papers():
    """Fig. 12: the angle grows with r2 (steeply near r1) and with d, and r2 matters more."""
    fig, sweeps = fig12(points=12, options=INTERPRETED)
    assert all(s.ok.all() for group in sweeps.values() for s in group)
    for s in sweeps["r2"] + sweeps["d"]:
        assert np.all(np.diff(s.total_angle_deg) > 0)
    # over the same 2 mm: r2 from 2 to 4 at d = 2 changes the angle more than d from 2 to 4 at r2 = 2
    by_r2 = sweep(Scene(pressure=0.2), r2=[2.0, 4.0], d=2.0, options=INTERPRETED).total_angle_deg
    by_d = sweep(Scene(pressure=0.2), r2=2.0, d=[2.0, 4.0], options=INTERPRETED).total_angle_deg
    assert by_r2[1] - by_r2[0] > by_d[1] - by_d[0] > 0
    # the figure shows each sweep: (a) the angle against r2 per d, (b) against d per r2
    ax_a, ax_b = fig.axes
    assert ax_a.get_xlabel() == "chamber radius r2 (mm)" and ax_b.get_xlabel() == "eccentric distance d (mm)"
    for ax, axis, group, name, values in ((ax_a, "r2", sweeps["r2"], "d", FIG12_D), (ax_b, "d", sweeps["d"], "r2", FIG12_R2)):
        assert drawn.legend(ax) == [f"{name} = {v:g} mm" for v in values]
        for line, s in zip(drawn.lines(ax), group):
            np.testing.assert_array_equal(drawn.xy(line)[0], s.points[axis])
            np.testing.assert_array_equal(drawn.xy(line)[1], s.total_angle_deg)


def test_sweep_figure(tmp_path):
    s = sweep(Scene(pressure=0.1), payload=[0.0, 1.0, 2.0], payload_angle=[0.0, 90.0], options=INTERPRETED)
    flat = sweep_figure(s, traced=False).axes[0]
    assert len(flat.lines) == 2  # one line per curve: the angle against the payload, per payload angle
    for line, omega in zip(flat.lines, (0.0, 90.0)):
        at = np.isclose(s.points["payload_angle"], omega)
        np.testing.assert_array_equal(drawn.xy(line)[0], s.points["payload"][at])
        np.testing.assert_array_equal(drawn.xy(line)[1], s.total_angle_deg[at])
    fig = sweep_figure(s)  # each curve a traced branch, the grid points as markers
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels[:2] == ["payload_angle = 0 deg", "payload_angle = 90 deg"]
    assert "grid points (each along its load history)" in labels
    big = sweep(Scene(), pressure=[0.05, 0.1], payload=[0.0, 1.0], payload_angle=[0.0, 90.0, 180.0], options=INTERPRETED)
    with pytest.raises(SweepError, match="6 curves"):
        sweep_figure(big, max_curves=4)
    assert sweep_figure(big).axes[0].get_xlabel() == "pressure (MPa)"


# ---------------------------------------------------------------------------------------------
# the command


def test_cli_sweep_csv(tmp_path, capsys):
    out = tmp_path / "s.csv"
    rc = main(["sweep", "--pressure", "0:0.2:3", "--payload", "0,2", "--no-compile", "--no-progress", "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "points: 6 ok, 0 not ok, 0 infeasible;" in text and "{'" not in text and f"wrote {out}" in text
    rows = list(csv.DictReader(out.open()))
    assert [float(r["pressure_mpa"]) for r in rows] == [0.0, 0.0, 0.1, 0.1, 0.2, 0.2]


def test_cli_sweep_json_and_infeasible(capsys):
    rc = main(["sweep", "--r2", "2,7", "--d", "4", "--target-angle", "90", "--no-compile", "--json"])
    assert rc == 0  # an infeasible design is a row that says so, not a failure
    data = json.loads(capsys.readouterr().out)
    assert [r["status"] for r in data["rows"]] == ["ok", "infeasible"]
    assert data["rows"][0]["total_angle_deg"] == pytest.approx(90.0)


def test_cli_sweep_table_of_infeasible_rows(capsys):
    """Each design at the pressure of its target angle: an infeasible one has no pressure (a dash, never nan)."""
    assert main(["sweep", "--r2", "2,7", "--d", "4", "--target-angle", "90", "--no-compile", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "infeasible" in out and "nan" not in out.lower()


def test_cli_sweep_usage_errors(capsys):
    assert main(["sweep"]) == 2
    assert "at least one axis" in capsys.readouterr().err
    assert main(["sweep", "--pressure", "1:2"]) == 2
    assert "start:stop:count" in capsys.readouterr().err
    assert main(["sweep", "--fig12", "x.png", "--r2", "1,2"]) == 2
    assert main(["sweep", "--pressure", "0.1", "--out", "x.txt", "--no-compile", "--no-progress"]) == 2


def test_cli_fig12(tmp_path, capsys, monkeypatch):
    saved = drawn.record_saved(monkeypatch)
    out = tmp_path / "fig12.png"
    assert main(["sweep", "--fig12", str(out), "--no-compile", "--no-progress"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "7 curves" in capsys.readouterr().out
    ax_a, ax_b = saved[out.resolve()].axes
    assert len(drawn.lines(ax_a)) == len(FIG12_D) and len(drawn.lines(ax_b)) == len(FIG12_R2)
    for line, d in zip(drawn.lines(ax_a), FIG12_D):  # each curve runs to the design-space edge
        assert drawn.xy(line)[0][-1] == pytest.approx(8.0 - d - 0.05) and np.all(np.isfinite(drawn.xy(line)[1]))


@pytest.mark.slow
@pytest.mark.ci
def test_full_design_space_sweep():
    """The whole (r2, d) design space at 0.2 MPa with a 1 N horizontal payload, compiled: every
    point ok or infeasible; a sample agrees with solve()."""
    r2 = list(np.linspace(0.1, 7.9, 40))
    d = list(np.linspace(0.0, 7.8, 40))
    s = sweep(Scene(pressure=0.2, payloads=(Payload(1.0, 90.0),)), r2=r2, d=d, options=BatchOptions(compile="auto", compile_min=1))
    assert set(s.status) <= {"ok", "infeasible"}, [m for m, st in zip(s.messages, s.status) if st == "not ok"][:3]
    feasible = np.flatnonzero(s.status == "ok")
    for i in feasible[:: max(1, len(feasible) // 10)]:
        act = Actuator(r2=s.points["r2"][i], d=s.points["d"][i])
        ref = solve(Scene(actuator=act, pressure=0.2, payloads=(Payload(1.0, 90.0),)))
        assert ref.ok
        np.testing.assert_allclose(s.theta[i], ref.theta, atol=BATCH_THETA_ATOL)


def test_the_scale_check_of_a_large_design_grid_is_bounded(monkeypatch):
    """check_resolvable looks at a handful of designs (the least stiff and the corners), not at
    every design of the grid: a 1000 x 1000 design grid is checked before its first chunk."""
    from esba.studies import sweep as sweep_module

    calls = []
    real = sweep_module.pressure_for_angle
    monkeypatch.setattr(sweep_module, "pressure_for_angle", lambda scene: calls.append(scene) or real(scene))
    plan = sweep_module.plan_sweep(Scene(), r2=list(np.linspace(0.5, 3.5, 1000)), d=list(np.linspace(0.0, 4.0, 1000)))
    sweep_module.check_resolvable(plan)
    assert 1 <= len(calls) <= 5
    designs = {(s.actuator.r2, s.actuator.d) for s in calls}
    assert (0.5, 0.0) in designs  # the thinnest concentric chamber: the largest pressure for the angle
    # the least stiff feasible design (largest r2 with the largest d it allows) is among them
    assert any(r2 == 3.5 and d == pytest.approx(4.0) for r2, d in designs)


def test_the_console_table_marks_points_that_snapped(capsys):
    """Pushed along its axis past the fold (2.904 N), the slightly inflated actuator snaps: the
    table says so on that row and counts it; the notes say where."""
    args = ["sweep", "--pressure", "0.001", "--payload", "2.8:3.0:3", "--payload-angle", "180", "--no-progress", "--no-compile"]
    assert main(args) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.strip().startswith("0.00100")]
    assert [line.endswith(", snapped") for line in rows] == [False, False, True]
    assert main([*args, "--json"]) == 0
    notes = [r["notes"] for r in json.loads(capsys.readouterr().out)["rows"]]
    assert "snap-through" in notes[2] and not notes[0]


def test_solve_points_reads_the_batch_verdict_once(monkeypatch):
    """``BatchResult.ok`` is computed over the whole batch at each access: read per point it made an
    in-process sweep O(N^2) (16 of 20 s at 64 000 points). It is read a bounded number of times."""
    from esba.statics import batch as batch_module
    from esba.studies.sweep import plan_sweep, solve_points

    reads = []
    original = batch_module.BatchResult.ok

    def counted(self):
        reads.append(1)
        return original.fget(self)

    monkeypatch.setattr(batch_module.BatchResult, "ok", property(counted))
    plan = plan_sweep(Scene(), pressure=list(np.linspace(0.02, 0.2, 40)))
    part = solve_points(plan, 0, plan.size, INTERPRETED)
    assert list(part["status"]) == ["ok"] * 40
    assert 1 <= len(reads) <= 2


def test_a_sweep_file_is_one_format_however_it_ran(capsys, tmp_path):
    """In this process and chunk by chunk (``--resume``), the CSV starts with its column names (so
    ``pandas.read_csv(FILE)`` reads it as it is) and the study's metadata is the file beside it."""
    from esba.studies.chunks import read_header, sidecar
    from esba.studies.sweep import row_fields

    grid = ["sweep", "--pressure", "0:0.2:5", "--payload", "0,1", "--no-compile", "--no-progress"]
    here, chunked = tmp_path / "here.csv", tmp_path / "chunked.csv"
    assert main([*grid, "--out", str(here)]) == 0
    assert main([*grid, "--out", str(chunked), "--resume", "--chunk", "3"]) == 0
    capsys.readouterr()
    assert here.read_bytes() == chunked.read_bytes()
    assert read_header(here) == read_header(chunked) and read_header(here)["rows"] == 10
    assert sidecar(here).name == "here.study.json"
    with open(here, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == row_fields(3) and len(rows) == 10
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_csv(chunked)
    assert list(frame.columns) == row_fields(3) and len(frame) == 10 and (frame["status"] == "ok").all()


def test_an_in_process_sweep_takes_over_its_own_study_and_resume_sees_it_done(capsys, tmp_path):
    """A file written in this process is the same study as on Dask: rerunning it says it starts
    over, and ``--resume`` on a finished file says that nothing was solved or written."""
    out = tmp_path / "s.csv"
    grid = ["sweep", "--pressure", "0:0.2:4", "--no-compile", "--no-progress", "--out", str(out)]
    assert main(grid) == 0
    before = out.read_bytes()
    capsys.readouterr()
    assert main([*grid, "--resume"]) == 0
    text = capsys.readouterr().out
    assert f"{out} already holds every row of this study (4): nothing solved, nothing written" in text
    assert f"wrote {out}" not in text and out.read_bytes() == before
    assert main(grid) == 0
    assert f"{out} held 4 rows of this study; starting over" in capsys.readouterr().err


def test_resume_refuses_a_file_with_its_metadata_inside(capsys, tmp_path):
    out = tmp_path / "old.csv"
    out.write_text('# esba-study {"kind": "sweep"}\npressure_mpa\n')
    assert main(["sweep", "--pressure", "0:0.2:4", "--no-compile", "--no-progress", "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert "written by an older esba" in err and len(err.strip().splitlines()) == 1
