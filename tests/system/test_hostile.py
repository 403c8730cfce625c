"""Bad and hostile input at every entry point: the CLI, scene files, the Python API, damaged cache
files and unwritable outputs.

Each case asserts the exit code (or esba's own exception type), one line naming the field or
file, no traceback, and no NaN in the output. The commands run in a temporary current folder,
so that nothing is written into the checkout.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from esba.cli import EXIT_FAILED, EXIT_OK, EXIT_USAGE, main
from esba.infra import cache, console

ROOT = Path(__file__).resolve().parents[2]


def strict_json(text: str):
    """json.loads that refuses NaN and Infinity, as strict parsers do."""

    def refuse(name):
        raise AssertionError(f"{name} in JSON output")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture
def places(tmp_path, monkeypatch):
    """A fresh current folder and the paths the cases refer to: {tmp}, {file}, {ro}, {missing}."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("not a folder\n")
    if os.geteuid() == 0:  # root writes anywhere chmod allows: /proc refuses even root
        ro = Path("/proc")
    else:
        ro = tmp_path / "readonly"
        ro.mkdir()
        ro.chmod(0o500)
    yield {"tmp": str(tmp_path), "file": str(tmp_path / "afile"), "ro": str(ro), "missing": str(tmp_path / "no" / "such")}
    if ro != Path("/proc"):
        ro.chmod(0o700)


#: The lines on stderr of a model generated on demand (esba.model.generated.generate_into_cache).
GENERATION_LINES = ("esba: generating the model for ", "esba:   n = ")


def one_line_error(capsys, argv, places, code=EXIT_USAGE) -> str:
    argv = [a.format(**places) for a in argv]
    got = main(argv)
    out, err = capsys.readouterr()
    assert got == code, f"{argv}: exit {got}, stderr {err!r}"
    assert out == "", out
    # a model this esba has not made yet is generated first, announced on stderr (whether it is
    # depends on which tests ran before): the error is the one line besides those
    lines = [line for line in err.strip().splitlines() if not line.startswith(GENERATION_LINES)]
    assert len(lines) == 1, err
    assert lines[0].startswith("esba: error: " if code == EXIT_USAGE else "esba: "), lines[0]
    assert "Traceback" not in err and "internal error" not in err
    assert "nan" not in lines[0].lower() or "nan" in " ".join(argv).lower()
    return lines[0]


# ---------------------------------------------------------------------------------------------
# the command line: flags

CLI = [
    (["solve", ""], "scene file '': expected the path of a TOML scene file"),
    (["solve", "   "], "scene file '   '"),
    (["solve", "--pressure", "0_1"], "'0_1' is not a number"),
    (["solve", "--pressure", "1e300"], "pressure=1e+300 MPa: expected at most 10 MPa"),
    (["solve", "--pressure", "nan"], "pressure=nan: expected a finite number"),
    (["solve", "--pressure", "inf"], "pressure=inf: expected a finite number"),
    (["solve", "--pressure", "-1"], "pressure=-1: expected a pressure >= 0 MPa"),
    (["solve", "--pressure", "0x1p-3"], "'0x1p-3' is not a number"),
    (["solve", "--segments", "1000000000"], "segments=1000000000: expected a whole number from 1 to 256"),
    (["solve", "-n", "257"], "segments=257: expected a whole number from 1 to 256"),
    (["solve", "--segments", "2.5"], "segments='2.5'"),
    (["solve", "--segments", "1_0"], "segments='1_0'"),
    (["solve", "--max-iter", "4294967296"], "max_iter=4294967296: expected a whole number from 1 to 100000"),
    (["solve", "--max-iter", "2147483648"], "max_iter=2147483648"),
    (["solve", "--max-iter", "1_000"], "max_iter=1_000"),
    (["solve", "--payload", "1e400"], "payload.force=inf: expected a finite number"),
    (["solve", "--payload", "1e300"], "payload.force=1e+300 N: expected at most 100 N"),
    (["solve", "--payload-at", "0"], "payload.at=0: expected a fraction of the length"),
    (["solve", "--payload-angle", "nan"], "payload.angle_deg=nan: expected a finite number"),
    (["solve", "--target-angle", "-5"], "target_angle_deg=-5: expected an angle > 0 degrees"),
    (["solve", "--target-angle", "1e400"], "target_angle_deg=inf: expected a finite number"),
    (["solve", "--plot", "x.png", "--no-plot"], "--plot and --no-plot: give one of the two"),
    (["solve", "--variant", "exact"], "invalid choice: 'exact'"),
    (["stiffness", "--payload", "0"], "forces=[0.0]: expected one or more payloads > 0 N"),
    (["stiffness", "--payload", "1e300"], "forces=[1e+300]: expected payloads of at most 100 N"),
    (["stiffness", "--payload-angle", "inf"], "angle_deg=inf: expected a finite number"),
    (["pressure"], "pressure needs a target"),
    (["pressure", "--target-angle", "90", "--payload", "1"], "--payload is not used with --target-angle"),
    (["pressure", "--target-angle", "90", "--gravity"], "--gravity is not used with --target-angle"),
    (["pressure", "--tip-x", "nan"], "tip_mm=[nan, None]: expected finite numbers in mm"),
    (["sweep", "--pressure", "0:0.2:10000", "--payload", "0:2:10000"], "the grid has 100000000 points (10000 pressure x 10000 payload): at most 200000"),
    (["sweep", "--pressure", "0:0.2:1000000"], "'0:0.2:1000000': expected start:stop:count (count from 1 to 200000)"),
    (["sweep", "--pressure", "0.1", "--target-angle", "45"], "--target-angle is not used with --pressure"),
    (["sweep", "--pressure", "0:1:0"], "'0:1:0': expected start:stop:count"),
    (["sweep", "--r2", "0_5"], "'0_5': expected start:stop:count"),
    (["sweep", "--pressure", "1e300", "--no-progress"], "pressure: 1e+300 MPa given; expected values <= 10"),
    (["sweep", "--no-progress"], "sweep needs at least one axis"),
    (["sweep", "--fig12", "f.png", "--out", "x.csv"], "--out is not used with --fig12"),
    (["sweep", "--r2", "0:1:3", "--no-progress"], "r2: 0 mm given; expected values > 0"),
    (["sweep", "--r2", "1e-300", "--pressure", "0.1", "--no-progress"], "actuator.r2=1e-300 mm: the chamber closes (Eq. 10)"),
    (["sweep", "--r2", "0.001:3:7", "--pressure", "0.1", "--no-progress"], "expected r2 >= 0.0107 mm for this actuator at n = 3"),
    (["sweep", "--pressure", "0:inf:3"], "'0:inf:3': expected start:stop:count"),
    (["sweep", "--pressure", "0.1", "--chunk", "7"], "--chunk is not used without --workers, --scheduler or --resume"),
    (["sweep", "--pressure", "0.1", "--connect-timeout", "5"], "--connect-timeout is the wait for --scheduler ADDRESS"),
    (["sweep", "--pressure", "0.1", "--chunk", "1_000", "--resume", "--out", "x.csv"], "argument --chunk: '1_000'"),
    (["solve", "--no-plot", "--seed", "5"], "--seed is not used without --monte-carlo N"),
    (["solve", "--no-plot", "--sigma", "E=10%", "--mc-chunk", "5"], "--mc-chunk is not used without --monte-carlo N"),
    (["solve", "--no-plot", "--sigma", "E=10%", "--monte-carlo", "10", "--seed", "1_0"], "argument --seed: '1_0'"),
    (["solve", "--no-plot", "-n", "256", "--sigma", "E=5%", "--monte-carlo", "1000000"], "samples=1000000 at n = 256 would keep about 4.0 GiB"),
    (["sweep", "--r2", "1:6:20", "--d", "0:1:20", "--payload", "0:2:20", "--payload-angle", "0:90:20", "--segments", "64", "--no-progress"], "the sweep of 160000 equilibria at n = 64 would take about"),
    (["design", "--method", "pso", "--particles", "100000", "--iterations", "100000"], "particles=100000 with iterations=100000"),
    (["design", "--particles", "1000000"], "particles=1000000: expected a whole number from 2 to 500000"),
    (["design", "--particles", "50"], "--particles is not used with --method ipopt"),
    (["design", "--method", "pso", "--starts", "3"], "--starts is not used with --method pso"),
    (["design", "--starts", "0"], "starts=0: expected a whole number from 1 to 8"),
    (["design", "--min-wall", "9"], "min_wall=9: expected 0 <= min_wall < r1 = 8 mm"),
    (["design", "--write-doc", "d.md", "--objective", "angle"], "--objective is not used with --write-doc"),
    (["generate", "--refresh", "--effects", "air"], "--effects is not used with --refresh"),
    (["generate", "--refresh", "--segments", "12", "--out", "{tmp}"], "--refresh --segments 12: the committed models are n = 1..8"),
    (["generate", "--segments", "1000"], "segments=1000: expected a whole number from 1 to 256"),
    (["generate", "--segments", "2", "--effects", "bogus"], "--effects: unknown effect 'bogus'"),
    (["generate"], "generate needs --segments N"),
    (["bench", "batch", "--size", "0"], "size=0: expected a whole number from 1 to 10000000"),
    (["bench", "batch", "--size", "10000000", "--segments", "64"], "--size of 10000000 equilibria at n = 64 would take about"),
    (["bench", "accuracy", "--quick", "--max-n", "8"], "--max-n is not used with --quick"),
    (["bench", "accuracy", "--no-write", "--out", "x.md"], "--out is not used with --no-write"),
    (["bench", "accuracy", "--reference-n", "6", "--no-write"], "--reference-n 6: expected a multiple of 4"),
    (["bench", "generation", "--repeat", "0"], "repeat=0: expected a whole number from 1 to 100"),
    (["bench", "generation", "--repeat", "1000000"], "repeat=1000000"),
    (["figures", "--only", "fig9"], "--only: unknown figure 'fig9'"),
    (["export", "c", "--segments", "0", "--out", "x"], "segments=0: expected a whole number from 1 to 256"),
    (["export", "c", "--segments", "257", "--out", "x"], "segments=257: expected a whole number from 1 to 256"),
    (["export", "c", "--segments", "3", "--effects", "air,bogus", "--out", "x"], "--effects: unknown effect 'bogus'"),
    (["export", "c", "--segments", "3", "--variant", "typo", "--out", "x"], "invalid choice: 'typo'"),
    (["export", "c", "--out", "x"], "the following arguments are required: --segments"),
    (["export", "c", "--segments", "3"], "the following arguments are required: --out"),
    (["export", "java", "--segments", "3"], "invalid choice: 'java'"),
    (["export"], "the following arguments are required: {c}"),
    (["bench", "embedded", "--repeat", "0"], "repeat=0: expected a whole number from 1 to 100"),
    (["bench", "embedded", "--segments", "65"], "segments=65: expected a whole number from 1 to 64"),
    (["bench", "embedded", "--no-write", "--out", "x.md"], "--out is not used with --no-write"),
    (["bench", "embedded", "--out", "x.txt"], "'.txt'; expected a file ending in .md"),
    (["equilibria", "--starts", "100000"], "--starts=100000: expected a whole number from 2 to 1000"),
    (["equilibria", "--max-bend", "nan", "--no-plot"], "--max-bend"),
    (["equilibria", "--pressure", "-1", "--no-plot"], "pressure"),
    (["equilibria", "--plot", "x.docx"], "docx"),
    (["solve", "--history", "2:0,1:1", "--no-plot"], "from 0 to 1"),
    (["solve", "--multistability", "maybe", "--no-plot"], "invalid choice: 'maybe'"),
    ([], "name a command"),
    (["bogus"], "invalid choice: 'bogus'"),
]


@pytest.mark.parametrize("argv, needle", CLI, ids=[" ".join(a) or "(nothing)" for a, _ in CLI])
def test_cli_refuses_bad_flags(capsys, places, argv, needle):
    line = one_line_error(capsys, argv, places)
    assert needle in line
    assert not any(Path(places["tmp"]).glob("*.png"))  # refused before anything was written


# ---------------------------------------------------------------------------------------------
# scene files

SCENES = {
    "garbage": None,  # random bytes
    "bad-toml": "segments = 3\n[actuator\n",
    "unknown-key": "[actuator]\nR1 = 8\n",
    "tiny-E": "[actuator]\nE = 1e-300\n",
    "huge-E-pressure": "[loads]\npressure = 1e300\n",
    "nan": "[loads]\npressure = nan\n",
    "inf-length": "[actuator]\nL = inf\n",
    "huge-n": "segments = 1000000000\n",
    "bool-n": "segments = true\n",
    "string-E": '[actuator]\nE = "soft"\n',
    "both-drives": "[loads]\npressure = 0.1\ntarget_angle_deg = 90\n",
    "chamber-outside": "[actuator]\nr2 = 5.0\n",
    "payload-no-force": "[[payloads]]\nangle_deg = 0\n",
    "17-payloads": "[[payloads]]\nforce = 1.0\n" * 17,
    "payloads-not-array": "payloads = 3\n",
}
SCENE_NEEDLES = {
    "garbage": "cannot be read",
    "bad-toml": "is not valid TOML",
    "unknown-key": "[actuator]: unknown key(s) R1",
    "tiny-E": "actuator.E=1e-300 MPa: the bending stiffness of a segment",
    "huge-E-pressure": "pressure=1e+300 MPa: expected at most 10 MPa",
    "nan": "pressure=nan: expected a finite number",
    "inf-length": "actuator.L=inf: expected a finite number",
    "huge-n": "segments=1000000000: expected a whole number from 1 to 256",
    "bool-n": "segments=True: expected a whole number",
    "string-E": "actuator.E='soft': expected a finite number",
    "both-drives": "give one of the two, not both",
    "chamber-outside": "the chamber must lie inside the actuator",
    "payload-no-force": "[[payloads]] #1: missing key force",
    "17-payloads": "payloads: 17 given",
    "payloads-not-array": "payloads=3: expected an array of tables",
}


@pytest.mark.parametrize("name", list(SCENES))
def test_scene_files_are_refused(capsys, places, name):
    path = Path(places["tmp"]) / f"{name}.toml"
    text = SCENES[name]
    path.write_bytes(np.random.default_rng(1).bytes(300) if text is None else text.encode())
    line = one_line_error(capsys, ["solve", str(path), "--no-plot"], places)
    assert SCENE_NEEDLES[name] in line
    assert name in line or "actuator.E" in line or "pressure=" in line  # the file or the field is named


def test_scene_file_that_is_a_folder(capsys, places):
    line = one_line_error(capsys, ["solve", "{tmp}", "--no-plot"], places)
    assert f"scene file '{places['tmp']}' cannot be read" in line


# ---------------------------------------------------------------------------------------------
# outputs that cannot be written: a missing folder, a file in the way, no permission, a bad suffix

OUTPUTS = [
    ["solve", "--plot", "{path}/x.png"],
    ["sweep", "--pressure", "0.1", "--out", "{path}/x.csv", "--no-progress"],
    ["sweep", "--pressure", "0.1", "--plot", "{path}/x.png", "--no-progress"],
    ["sweep", "--fig12", "{path}/f.png", "--no-progress"],
    ["design", "--plot", "{path}/d.png"],
    ["design", "--write-doc", "{path}/design.md"],
    ["validate", "--out", "{path}/v.md"],
    ["audit", "--out", "{path}/d.md"],
    ["figures", "--out", "{path}/figs"],
    ["bench", "accuracy", "--quick", "--out", "{path}/a.md"],
    ["bench", "accuracy", "--quick", "--figure", "{path}/a.png"],
    ["bench", "generation", "--max-n", "2", "--markdown", "{path}/p.md"],
    ["generate", "--segments", "2", "--out", "{path}/gen"],
    ["export", "c", "--segments", "2", "--out", "{path}/ctrl"],
    ["bench", "embedded", "--segments", "3", "--out", "{path}/e.md"],
]
WHERE = {"missing": ("missing", "does not exist"), "file-in-the-way": ("file", "is a file"), "no-permission": ("ro", "cannot ")}


@pytest.mark.parametrize("kind", list(WHERE))
@pytest.mark.parametrize("argv", OUTPUTS, ids=[" ".join(a[:2]) + " " + next(x for x in a if "{path}" in x).split("/")[-1] for a in OUTPUTS])
def test_unwritable_outputs_are_refused_up_front(capsys, places, kind, argv):
    where, needle = WHERE[kind]
    path = places[where]
    line = one_line_error(capsys, [a.replace("{path}", path) for a in argv], places)
    assert needle in line
    assert path in line  # the file or folder is named


@pytest.mark.parametrize(
    "argv",
    [["solve", "--plot", "shape.xyz"], ["sweep", "--pressure", "0.1", "--plot", "s.v2"], ["design", "--plot", "d.docx"], ["sweep", "--fig12", "f.txt"], ["bench", "accuracy", "--quick", "--figure", "a.md"]],
)
def test_unsupported_figure_suffix(capsys, places, argv):
    line = one_line_error(capsys, argv, places)
    assert "unsupported figure format" in line and ".png" in line


def test_sweep_out_needs_csv_or_json(capsys, places):
    line = one_line_error(capsys, ["sweep", "--pressure", "0.1", "--out", "grid.txt"], places)
    assert "--out 'grid.txt': '.txt'; expected a file ending in .csv, .json" in line


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (a device whose writes fail: disk full)")
def test_a_full_disk_is_one_line_naming_the_file_exit_1(capsys, places):
    """The folder is fine (the checks up front pass) but the disk fills while the file is written."""
    (Path(places["tmp"]) / "grid.json").symlink_to("/dev/full")
    line = one_line_error(capsys, ["sweep", "--pressure", "0,0.1", "--no-compile", "--no-progress", "--out", "grid.json"], places, code=EXIT_FAILED)
    assert line == "esba: error: grid.json: cannot write (No space left on device)"


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (a device whose writes fail: disk full)")
def test_a_full_disk_for_a_sweeps_metadata_is_exit_1_and_keeps_the_old_csv(capsys, places):
    """The metadata is written (beside the CSV, through a temporary file) before the CSV is cut: when
    the disk fills there, the run fails (exit 1, naming the file) and the CSV keeps what it held."""
    tmp = Path(places["tmp"])
    (tmp / "grid.csv").write_text("old,rows\n1,2\n")
    (tmp / f"grid.study.json.{os.getpid()}.tmp").symlink_to("/dev/full")
    line = one_line_error(capsys, ["sweep", "--pressure", "0,0.1", "--no-compile", "--no-progress", "--out", "grid.csv"], places, code=EXIT_FAILED)
    assert line.startswith("esba: error: grid.study.json: cannot write the study's metadata (No space left on device)")
    assert (tmp / "grid.csv").read_text() == "old,rows\n1,2\n"
    assert not (tmp / "grid.study.json").exists()


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_sweep_csv_that_is_a_device_is_refused_up_front(capsys, places):
    """A CSV is a study file however the sweep runs (it can be resumed): a device in its place is refused
    before anything is solved, as for --resume."""
    (Path(places["tmp"]) / "grid.csv").symlink_to("/dev/full")
    line = one_line_error(capsys, ["sweep", "--pressure", "0,0.1", "--no-compile", "--no-progress", "--out", "grid.csv"], places)
    assert line.startswith("esba: error: grid.csv: ") and "not a regular file" in line


def test_figure_folder_and_suffixless_name_say_what_was_written(capsys, places):
    tmp = Path(places["tmp"])
    (tmp / "figs").mkdir()
    assert main(["solve", "--plot", "figs", "--json"]) == EXIT_OK
    data = strict_json(capsys.readouterr().out)
    assert data["figure"] == str(tmp / "figs" / "esba-solve.png") and Path(data["figure"]).is_file()
    assert main(["solve", "--plot", "shape"]) == EXIT_OK
    out = capsys.readouterr().out
    assert f"wrote {tmp / 'shape.png'}" in out and (tmp / "shape.png").is_file() and not (tmp / "shape").exists()


# ---------------------------------------------------------------------------------------------
# the Python API: the checks the CLI makes, as esba's own exception types


def _api_cases():
    from esba.derive.effects import EffectError
    from esba.analysis import stiffness
    from esba.design import optimise as design
    from esba.figures.paper import FigureError, write_all
    from esba.model.generated import load_model
    from esba.model.scene import MAIN_JOB, Actuator, Payload, Scene, SceneError
    from esba.solvers import pso
    from esba.statics import batch
    from esba.statics.equilibrium import (
        SolverOptions,
        SolverOptionsError,
        evaluate,
        solve,
    )
    from esba.studies import sweep

    nan, inf = float("nan"), float("inf")
    return [
        ("solve(None)", lambda: solve(None), SceneError, "scene=None: expected an esba.model.scene.Scene"),
        ("solve(pressure=nan)", lambda: solve(MAIN_JOB, pressure=nan), SceneError, "pressure=nan: expected a finite number"),
        ("solve(pressure=inf)", lambda: solve(MAIN_JOB, pressure=inf), SceneError, "pressure=inf: expected a finite number"),
        ("solve(pressure=-1)", lambda: solve(MAIN_JOB, pressure=-1), SceneError, "pressure=-1: expected a pressure >= 0 MPa"),
        ("solve(pressure='1')", lambda: solve(MAIN_JOB, pressure="1"), SceneError, "pressure='1': expected a finite number"),
        ("solve(options='fast')", lambda: solve(MAIN_JOB, "fast"), SolverOptionsError, "options='fast': expected a SolverOptions"),
        ("solve(theta0='abc')", lambda: solve(MAIN_JOB, theta0="abc"), SolverOptionsError, "theta0='abc': expected 3 finite angles"),
        ("solve(theta0=[nan]*3)", lambda: solve(MAIN_JOB, theta0=[nan] * 3), SolverOptionsError, "theta0 has shape (3,): expected 3 finite angles"),
        ("solve(E=1e-300)", lambda: solve(MAIN_JOB.replace(E=1e-300)), SceneError, "actuator.E=1e-300 MPa"),
        ("solve(P=1e300)", lambda: solve(MAIN_JOB.replace(pressure=1e300)), SceneError, "pressure=1e+300 MPa"),
        ("evaluate(theta=[nan,0,0])", lambda: evaluate(MAIN_JOB, [nan, 0.0, 0.0]), SolverOptionsError, "theta has shape (3,)"),
        ("evaluate(None)", lambda: evaluate(None, [0.0]), SceneError, "scene=None"),
        ("SolverOptions(max_iter=2**31)", lambda: SolverOptions(max_iter=2**31), SolverOptionsError, "max_iter=2147483648: expected a whole number from 1 to 100000"),
        ("SolverOptions(samples_per_segment=10**6)", lambda: SolverOptions(samples_per_segment=10**6), SolverOptionsError, "samples_per_segment=1000000"),
        ("Scene(segments=10**9)", lambda: Scene(segments=10**9), SceneError, "segments=1000000000: expected a whole number from 1 to 256"),
        ("Actuator(E=nan)", lambda: Actuator(E=nan), SceneError, "actuator.E=nan: expected a finite number"),
        ("Payload(force=inf)", lambda: Payload(inf), SceneError, "payload.force=inf: expected a finite number"),
        ("load_model(10**9)", lambda: load_model(10**9), EffectError, "segments=1000000000: expected a whole number from 1 to 256"),
        ("load_model('3')", lambda: load_model("3"), EffectError, "segments='3'"),
        ("sweep(huge grid)", lambda: sweep.sweep(Scene(pressure=0.1), pressure=np.linspace(0, 0.2, 10_000), payload=np.linspace(0, 2, 10_000)), sweep.SweepError, "the grid has 100000000 points"),
        ("sweep(base=None)", lambda: sweep.sweep("scene", pressure=[0.1]), sweep.SweepError, "base='scene': expected a Scene"),
        ("parse_values('0_1')", lambda: sweep.parse_values("0_1"), sweep.SweepError, "'0_1': expected start:stop:count"),
        ("PSOOptions(10**6 x 10**6)", lambda: pso.PSOOptions(particles=10**5, iterations=10**5), pso.PSOOptionsError, "particles=100000 with iterations=100000"),
        ("PSOOptions(max_tries=10**12)", lambda: pso.PSOOptions(max_tries=10**12), pso.PSOOptionsError, "max_tries=1000000000000"),
        ("BatchOptions(chunk=10**9)", lambda: batch.BatchOptions(chunk=10**9), batch.BatchOptionsError, "chunk=1000000000: expected a whole number from 1 to 100000"),
        ("solve_arrays(too big)", lambda: batch.solve_arrays(load_model(3), {**MAIN_JOB.parameters(0.1), "P": np.zeros(5_000_000)}), batch.BatchOptionsError, "a batch of 5000000 equilibria at n = 3 would take"),
        ("DesignOptions(max_iter=2**31)", lambda: design.DesignOptions(max_iter=2**31), design.DesignError, "max_iter=2147483648"),
        ("DesignProblem(segments=10**6)", lambda: design.DesignProblem(segments=10**6), design.DesignError, "segments=1000000"),
        ("secant_stiffness(None)", lambda: stiffness.secant_stiffness(None), SceneError, "scene=None"),
        ("secant_stiffness(forces=['a'])", lambda: stiffness.secant_stiffness(MAIN_JOB, ["a"]), SceneError, "forces=['a']"),
        ("secant_stiffness(forces=[nan])", lambda: stiffness.secant_stiffness(MAIN_JOB, [nan]), SceneError, "forces=[nan]"),
        ("pressure_for_target(tip_mm=5)", lambda: stiffness.pressure_for_target(MAIN_JOB, tip_mm=5), SceneError, "tip_mm=5: expected [x, y] in mm"),
        ("pressure_for_target(total='x')", lambda: stiffness.pressure_for_target(MAIN_JOB, total_angle_deg="x"), SceneError, "total_angle_deg='x': expected a finite number"),
        ("write_all(names=['fig9'])", lambda: write_all("unused", ["fig9"]), FigureError, "unknown figure 'fig9'"),
    ]


API = _api_cases()


@pytest.mark.parametrize("case", API, ids=[c[0] for c in API])
def test_python_api_checks_what_the_cli_checks(case):
    _, call, error, needle = case
    with pytest.raises(error) as info:
        call()
    message = str(info.value)
    assert needle in message
    assert "\n" not in message
    assert type(info.value).__module__.split(".")[0] == "esba"  # esba's own exception types (esba.derive's too)


def test_api_and_cli_say_the_same(capsys, places):
    from esba.model.scene import MAIN_JOB, SceneError
    from esba.statics.equilibrium import solve

    for flag, value in (("--pressure", "nan"), ("--pressure", "-1"), ("--pressure", "inf")):
        line = one_line_error(capsys, ["solve", flag, value, "--no-plot"], places)
        with pytest.raises(SceneError) as info:
            solve(MAIN_JOB, pressure=float(value))
        assert line == f"esba: error: {info.value}"


# ---------------------------------------------------------------------------------------------
# the model cache: damaged files are reported in one line naming them, and made again


@pytest.fixture(scope="module")
def template_cache(tmp_path_factory):
    """A cache holding one model generated on demand (n = 2, no payload: not committed)."""
    from esba.model import generated as model

    folder = tmp_path_factory.mktemp("template-cache")
    old = os.environ.get("ESBA_CACHE_DIR")
    os.environ["ESBA_CACHE_DIR"] = str(folder)
    try:
        model._load.cache_clear()
        m = model.load_model(2, "air,axial,radial,fibres")
        path = m.path
    finally:
        if old is None:
            del os.environ["ESBA_CACHE_DIR"]
        else:
            os.environ["ESBA_CACHE_DIR"] = old
        model._load.cache_clear()
    return folder, path.relative_to(folder)


def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 3])
    elif how == "garbage":
        path.write_bytes(np.random.default_rng(0).bytes(len(data)))
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "folder":
        path.unlink()
        path.mkdir()
        (path / "inside").write_text("x")
    elif how == "other-format":  # a consistent file (checksum rewritten) of a format this esba does not read
        cache.write_bytes(path, data.replace(b"\nFORMAT = 1\n", b"\nFORMAT = 2\n"))
    elif how == "other-model":  # the bytes of another model under this name, checksum and all
        cache.write_bytes(path, data.replace(b"\nN = 2\n", b"\nN = 5\n"))
    elif how == "no-checksum":
        cache.record_path(path).unlink()
    elif how == "bad-checksum-record":
        cache.record_path(path).write_text("{not json")
    else:  # pragma: no cover
        raise ValueError(how)


DAMAGE = ["truncated", "garbage", "empty", "folder", "other-format", "other-model", "no-checksum", "bad-checksum-record"]


@pytest.mark.parametrize("how", DAMAGE)
def test_damaged_cached_model_is_reported_and_regenerated(capsys, places, monkeypatch, template_cache, how):
    from esba.model import generated as model

    template, rel = template_cache
    folder = Path(places["tmp"]) / "cache"
    shutil.copytree(template, folder)
    monkeypatch.setenv("ESBA_CACHE_DIR", str(folder))
    model._load.cache_clear()
    path = folder / rel
    _damage(path, how)
    try:
        code = main(["solve", "--segments", "2", "--no-payload", "--no-plot", "--json"])
    finally:
        model._load.cache_clear()
    out, err = capsys.readouterr()
    assert code == EXIT_OK, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"esba: cached model {path} is damaged (") and "generating it again" in lines[0]
    assert "Traceback" not in err
    assert strict_json(out)["ok"] is True
    assert path.is_file() and cache.damage(path) is None  # made again, with its checksum
    assert path.stat().st_mode & 0o777 == 0o644


def test_damaged_committed_model_is_not_executed(capsys, places, monkeypatch, tmp_path):
    """A committed model that does not match the manifest's sha256 is reported and replaced by a cached copy."""
    from esba.derive import provenance
    from esba.model import generated as model

    committed = tmp_path / "generated"
    shutil.copytree(ROOT / "generated", committed)
    name = "m_n002__air_axial_radial_fibres_payload1__paper.py"
    (committed / name).write_text("raise SystemExit('executed a damaged file')\n")
    monkeypatch.setattr(model, "GENERATED_DIR", committed)
    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path / "cache"))
    model._load.cache_clear()
    try:
        code = main(["solve", "--segments", "2", "--no-plot", "--json"])
    finally:
        model._load.cache_clear()
    out, err = capsys.readouterr()
    assert code == EXIT_OK, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and f"committed model {committed / name} does not match the sha256" in lines[0]
    assert strict_json(out)["ok"] is True
    assert provenance.GENERATED_DIR != committed  # the real one untouched


@pytest.mark.parametrize("where", ["a-file", "unwritable", "under-a-file"])
def test_unusable_cache_folder_fails_in_one_line_before_generating(capsys, places, monkeypatch, where):
    from esba.model import generated as model

    target = {"a-file": places["file"], "unwritable": places["ro"] + "/esba-cache", "under-a-file": places["file"] + "/cache"}[where]
    monkeypatch.setenv("ESBA_CACHE_DIR", target)
    model._load.cache_clear()
    try:
        line = one_line_error(capsys, ["solve", "--segments", "9", "--no-payload", "--no-plot"], places)
    finally:
        model._load.cache_clear()
    assert line.startswith(f"esba: error: ESBA_CACHE_DIR='{target}'")
    assert "point ESBA_CACHE_DIR at a writable folder" in line


def test_generation_on_demand_says_so_on_stderr(capsys, places, monkeypatch):
    from esba.model import generated as model

    monkeypatch.setenv("ESBA_CACHE_DIR", str(Path(places["tmp"]) / "cache"))
    model._load.cache_clear()
    try:
        assert main(["solve", "--segments", "1", "--no-payload", "--gravity", "--no-plot"]) == EXIT_OK
    finally:
        model._load.cache_clear()
    err = capsys.readouterr().err
    assert err.startswith("esba: generating the model for n = 1 (air,axial,radial,fibres,gravity, paper) into ")
    lines = err.strip().splitlines()  # the announcement, then a line as each stage ends, nothing else
    assert len(lines) == 3 and "derived" in lines[1] and "CasADi code written" in lines[2]
    assert all(line.startswith("esba:   n = 1: ") for line in lines[1:])
    made = next((Path(places["tmp"]) / "cache").rglob("*.py"))
    assert made.stat().st_mode & 0o777 == 0o644 and cache.damage(made) is None


@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="needs a C compiler")
def test_damaged_compiled_library_is_rebuilt_not_loaded(tmp_path):
    """A truncated shared library used to kill the process with a bus error when loaded."""
    env = {**os.environ, "ESBA_CACHE_DIR": str(tmp_path / "cache")}
    argv = [sys.executable, "-m", "esba.cli", "sweep", "--pressure", "0:0.2:600", "--no-progress", "--json"]
    first = subprocess.run(argv, env=env, capture_output=True, text=True, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    libs = list((tmp_path / "cache" / "compiled").glob("*.so"))
    assert len(libs) == 1
    lib = libs[0]
    lib.write_bytes(lib.read_bytes()[:4096])
    again = subprocess.run(argv, env=env, capture_output=True, text=True, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    lines = again.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"esba: compiled batch solver {lib} is damaged (truncated")
    assert strict_json(again.stdout)["counts"]["ok"] == 600
    assert cache.damage(lib) is None and lib.stat().st_mode & 0o777 == 0o644


# ---------------------------------------------------------------------------------------------
# the terminal: closed pipes, --version, valid JSON


def test_output_piped_into_head_ends_quietly(tmp_path):
    esba = [sys.executable, "-m", "esba.cli"]
    for argv in (["sweep", "--pressure", "0:0.2:300", "--no-progress", "--json", "--no-compile"], ["solve", "--no-plot"]):
        proc = subprocess.Popen(esba + argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path, env={**os.environ, "ESBA_CACHE_DIR": str(tmp_path / "cache")})
        proc.stdout.readline()
        proc.stdout.close()  # the reader goes away, as `head -1` does
        err = proc.stderr.read().decode()
        proc.wait(timeout=120)
        assert "Traceback" not in err and "BrokenPipe" not in err and "Exception ignored" not in err, err
        assert proc.returncode in (0, console.EXIT_PIPE)


def test_version(capsys):
    import importlib.metadata

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"esba {importlib.metadata.version('esba')}"


@pytest.mark.parametrize(
    "argv",
    [
        ["sweep", "--r2", "6,7", "--d", "0,1.5", "--target-angle", "45", "--no-progress", "--json"],  # an infeasible point swept by angle
        ["bench", "generation", "--max-n", "2", "--repeat", "1", "--no-naive", "--json"],  # too few n for a growth exponent
        ["stiffness", "--json"],
        ["solve", "--pressure", "5", "--no-plot", "--json"],
    ],
)
def test_json_is_strict_json(capsys, places, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    assert code in (EXIT_OK, EXIT_FAILED), err
    data = strict_json(out)
    assert "Traceback" not in err
    text = json.dumps(data)
    assert "NaN" not in text and "Infinity" not in text
    if argv[0] == "bench":
        assert data["growth_exponent"] is None and "needs at least two n >= 16" in data["growth_exponent_reason"]
    if argv[0] == "sweep":
        rows = [r for r in data["rows"] if r["status"] == "infeasible"]
        assert rows and all(r["pressure_mpa"] is None for r in rows)


def test_growth_exponent_not_printed_as_nan(capsys, places):
    assert main(["bench", "generation", "--max-n", "2", "--repeat", "1", "--no-naive"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "nan" not in out and "growth exponent not computed: needs at least two n >= 16" in out


def test_nothing_is_written_into_the_package_when_run_elsewhere(capsys, places):
    """Outside a checkout the pages and figures go to docs/ in the current folder."""
    from esba.infra import outputs

    tmp = Path(places["tmp"])
    assert outputs.checkout_root() is None
    assert outputs.default_page("validation.md") == tmp / "docs" / "validation.md"
    assert main(["validate"]) == EXIT_OK
    assert (tmp / "docs" / "validation.md").is_file()
    assert main(["figures", "--only", "fig7b"]) == EXIT_OK
    assert (tmp / "docs" / "figures" / "fig7b.png").is_file()
    capsys.readouterr()
    assert main(["generate", "--refresh"]) == EXIT_USAGE
    assert "run it inside a checkout, or give --out DIR" in capsys.readouterr().err


def test_large_values_do_not_flood_stderr(tmp_path):
    """--pressure 1e300 gave 158,806 lines of CasADi warnings; now one line, and never "stable"."""
    proc = subprocess.run(
        [sys.executable, "-m", "esba.cli", "solve", "--pressure", "1e300", "--no-plot"],
        capture_output=True, text=True, cwd=tmp_path, env={**os.environ, "ESBA_CACHE_DIR": str(tmp_path / "cache")},
    )
    assert proc.returncode == EXIT_USAGE
    assert proc.stdout == "" and len(proc.stderr.strip().splitlines()) == 1
    assert "stable" not in proc.stderr


def test_non_finite_model_values_are_never_stable():
    """Where the model overflows, the result is not ok and not stable (no verdict from NaN)."""
    from esba.model.scene import MAIN_JOB
    from esba.statics.equilibrium import evaluate

    r = evaluate(MAIN_JOB.replace(pressure=0.1), [1e300, 0.0, 0.0])
    assert not r.ok and r.stability != "stable" and r.status == "Not_Finite"
    assert math.isnan(r.eigenvalues[0])


def test_refresh_of_one_segment_count_writes_only_those(capsys, places):
    out = Path(places["tmp"]) / "gen"
    out.mkdir()
    assert main(["generate", "--refresh", "--segments", "1", "--out", str(out), "--json"]) == EXIT_OK
    data = strict_json(capsys.readouterr().out)
    assert data["refreshed"] == ["m_n001__air_axial_radial_fibres_payload1__paper.py", "m_n001__air_axial_radial_fibres_payload1__printed.py"]
    assert sorted(p.name for p in out.iterdir()) == sorted(data["refreshed"] + ["manifest.json"])
    committed = ROOT / "generated" / data["refreshed"][0]
    assert (out / data["refreshed"][0]).read_bytes() == committed.read_bytes()
    umask = os.umask(0)
    os.umask(umask)
    for p in out.iterdir():  # written through temporary files (0600), then given the user's mode
        assert p.stat().st_mode & 0o777 == 0o666 & ~umask, p.name


def test_small_benchmark_batches_run(capsys, places):
    """Batch sizes below the 50 IPOPT samples crashed with a traceback."""
    assert main(["bench", "batch", "--size", "10", "--json"]) == EXIT_OK
    data = strict_json(capsys.readouterr().out)
    assert data["size"] == 9 and data["ipopt_samples"] == 9  # a 3 x 3 grid of pressures and payloads


# ---------------------------------------------------------------------------------------------
# second round: flags that must agree, sigmas outside the model, the API's own errors, special
# files, short messages, resumed studies that lie

ROUND2_FLAGS = [
    (["path", "--to", "0.2", "--out", "", "--no-plot"], "--out '': expected a file name"),
    (["path", "--to", "0.2", "--out", "x.csv", "--no-out", "--no-plot"], "--out and --no-out: give one of the two"),
    (["path", "--to", "0.2", "--plot", "x.png", "--no-plot", "--no-out"], "--plot and --no-plot: give one of the two"),
    (["sweep", "--pressure", "1,,2", "--no-progress"], "'1,,2': expected start:stop:count"),
    (["sweep", "--pressure", "0.1,", "--no-progress"], "'0.1,': expected start:stop:count"),
    (["solve", "--no-plot", "--sigma", "E=1_0%"], "--sigma 'E=1_0%': expected NAME=SIGMA"),
    (["solve", "--no-plot", "--sigma", "E=\u0661\u0660%"], "--sigma 'E=\u0661\u0660%': expected NAME=SIGMA"),
    (["solve", "--no-plot", "--pressure", "\u0661"], "'\u0661' is not a number"),
    (["solve", "--no-plot", "--segments", "\u0663"], "segments='\u0663'"),
    (["solve", "--no-plot", "--sigma", "E=1e308"], "--sigma 'E=1e308': 3 sigma is not a finite number"),
    (["design", "--write-doc", "d.txt"], "--write-doc 'd.txt': '.txt'; expected a file ending in .md"),
    (["validate", "--out", "v.txt"], "--out 'v.txt': '.txt'; expected a file ending in .md"),
    (["audit", "--out", "v.txt"], "--out 'v.txt': '.txt'; expected a file ending in .md"),
    (["solve", "--plot", "x.png/"], "--plot 'x.png/': ends in '/' but is not an existing folder"),
    (["sweep", "--pressure", "0.1", "--out", "g.csv/", "--no-progress"], "--out 'g.csv/': ends in '/'"),
    (["design", "--max-pressure", "1e9"], "max_pressure=1e+09 MPa: its moment on a segment"),
    (["map", "--x", "omega:110:135", "--y", "payload:0:4", "--out", "", "--no-plot"], "--out '': expected a file name"),
    (["map", "--x", "omega:110:135", "--y", "payload:0:4", "--plot", "", "--no-out"], "--plot '': expected a figure file"),
    (["sweep", "--pressure", "0.1", "--out", "", "--no-progress"], "--out '': expected a file name"),
    (["sweep", "--pressure", "0.1", "--plot", "", "--no-progress"], "--plot '': expected a figure file"),
    (["sweep", "--fig12", "", "--no-progress"], "--fig12 '': expected a figure file"),
    (["solve", "--plot", ""], "--plot '': expected a figure file"),
    (["equilibria", "--plot", ""], "--plot '': expected a figure file"),
    (["design", "--plot", ""], "--plot '': expected a figure file"),
    (["solve", "--no-plot", "--history", ""], "--history '': expected a name"),
    (["solve", "--no-plot", "--history", "  "], "--history '': expected a name"),
    (["stiffness", "--payload", "1e-300", "--json"], "payload 1e-300 N: below 1e-09 N"),
    (["pressure", "--target-angle", "1e6"], "target_angle_deg=1e+06: expected an angle <= 3600 degrees"),
    (["design", "--objective", "pressure", "--min-stiffness", "30", "--target-angle", "1e6"], "target_angle_deg=1e+06: expected an angle <= 3600 degrees"),
]


@pytest.mark.parametrize("argv, needle", ROUND2_FLAGS, ids=[" ".join(a) for a, _ in ROUND2_FLAGS])
def test_flags_agree_with_each_other(capsys, places, argv, needle):
    line = one_line_error(capsys, argv, places)
    assert needle in line
    assert sorted(p.name for p in Path(places["tmp"]).iterdir()) in (["afile"], ["afile", "readonly"])  # nothing written


@pytest.mark.parametrize("field, value, needle", [("L", "1e-300", "actuator.L=1e-300 mm: the bending stiffness"), ("E", "1e300", "actuator.E=1e+300 MPa: the bending stiffness")])
def test_extreme_length_or_modulus_is_bad_input_naming_it(capsys, places, field, value, needle):
    path = Path(places["tmp"]) / "extreme.toml"
    path.write_text(f"[actuator]\n{field} = {value}\n")
    line = one_line_error(capsys, ["solve", str(path), "--no-plot"], places)
    assert needle in line


def test_sigma_leaving_its_domain_is_warned_of_with_the_domain(capsys, places):
    assert main(["solve", "--no-plot", "--json", "--sigma", "E=1000%", "--sigma", "rho=±100", "--sigma", "s1=±1", "--monte-carlo", "50"]) == EXIT_OK
    out, err = capsys.readouterr()
    data = strict_json(out)
    warned = data["uncertainty"]["outside_domain"]
    assert len(warned) == 3
    text = " | ".join(warned)  # in the scene's parameter order
    assert "beyond the domain E > 0 MPa" in text and "beyond the domain 0 <= rho < 90 deg" in text and "0 < s1 <= 1" in text
    for line in warned:
        assert f"esba: warning: {line}" in err
    c = data["monte_carlo"]["counts"]
    assert c["invalid"] > 0 and c["ok"] + c["invalid"] + c["not_ok"] == 50  # counted, and said in the table
    assert "Traceback" not in err and "RuntimeWarning" not in err


def test_sigma_whose_covariance_overflows_is_not_ok(capsys, places):
    assert main(["solve", "--no-plot", "--json", "--sigma", "E=1e200"]) == EXIT_OK
    out, err = capsys.readouterr()
    u = strict_json(out)["uncertainty"]
    assert u["status"] == "overflow" and u["std_tip_mm"] is None and "overflows" in u["message"]
    assert "RuntimeWarning" not in err


def _special(tmp: Path, kind: str, name: str) -> Path:
    path = tmp / name
    if kind == "fifo":
        os.mkfifo(path)  # a read would wait for a writer forever
    elif kind == "dev-zero":
        path.symlink_to("/dev/zero")  # a read would never end
    elif kind == "link-to-fifo":
        os.mkfifo(tmp / ("real-" + name))
        path.symlink_to(tmp / ("real-" + name))
    return path


SPECIAL = {"fifo": "a FIFO (named pipe)", "dev-zero": "a character device (through a symlink)", "link-to-fifo": "a FIFO (named pipe) (through a symlink)"}


@pytest.mark.skipif(not hasattr(os, "mkfifo") or not os.path.exists("/dev/zero"), reason="needs FIFOs and /dev/zero")
@pytest.mark.parametrize("kind", list(SPECIAL))
@pytest.mark.parametrize("argv, name, what", [(["solve", "{path}", "--no-plot"], "s.toml", "scene file"), (["fit", "{path}"], "m.csv", "measurement file"), (["fit", "{path}"], "m.toml", "measurement file")])
def test_special_input_files_are_one_line_without_a_hang(capsys, places, kind, argv, name, what):
    path = _special(Path(places["tmp"]), kind, name)
    line = one_line_error(capsys, [a.replace("{path}", str(path)) for a in argv], places)
    assert line == f"esba: error: {what} {str(path)!r} cannot be read: {SPECIAL[kind]}, not a regular file"


@pytest.mark.parametrize("argv, name", [(["solve", "{path}", "--no-plot"], "deep.toml"), (["fit", "{path}"], "deep-m.toml")])
def test_toml_nested_5000_deep_is_one_line(capsys, places, argv, name):
    path = Path(places["tmp"]) / name
    path.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    line = one_line_error(capsys, [a.replace("{path}", str(path)) for a in argv], places)
    assert "not valid TOML: nested too deeply" in line and name in line


def test_a_byte_order_mark_is_read_alike_in_scene_and_measurement_files(capsys, places):
    tmp = Path(places["tmp"])
    (tmp / "bom.toml").write_bytes(b"\xef\xbb\xbfsegments = 2\n[loads]\npressure = 0.1\n")
    (tmp / "bom.csv").write_bytes(b"\xef\xbb\xbfpressure_mpa,total_angle_deg\n0.1,50\n0.12,70\n")
    assert main(["solve", str(tmp / "bom.toml"), "--no-plot", "--json"]) == EXIT_OK
    assert strict_json(capsys.readouterr().out)["scene"].endswith("n=2, paper")
    assert main(["fit", str(tmp / "bom.csv"), "--free", "E", "--json"]) == EXIT_OK
    assert strict_json(capsys.readouterr().out)


@pytest.mark.parametrize(
    "text, needle",
    [
        ("[actuator]\n" + "".join(f"k{i} = 1\n" for i in range(100_000)), "unknown key(s) k0, k1, k10, k100, k1000 and 99995 more"),
        ('variant = "' + "x" * 10_000_000 + '"\n', "variant='xxxx"),
        ("[actuator]\nE = \"" + "y" * 10_000_000 + '"\n', "(10000000 characters): expected a finite number"),
    ],
    ids=["100000-unknown-keys", "10-MB-variant", "10-MB-E"],
)
def test_messages_cap_what_they_quote(capsys, places, text, needle):
    path = Path(places["tmp"]) / "huge.toml"
    path.write_text(text)
    line = one_line_error(capsys, ["solve", str(path), "--no-plot"], places)
    assert needle in line and len(line) < 300


MEASUREMENTS = {
    "two-pressures.csv": ("pressure_mpa,pressure_kpa,total_angle_deg\n0.1,120,50\n", "pressure_mpa=0.1 and pressure_kpa=120 disagree (0.1 vs 0.12 MPa); give the pressure once"),
    "two-pressures.toml": ("[[measurement]]\npressure_mpa = 0.1\npressure_bar = 2\ntotal_angle_deg = 50\n", "pressure_mpa=0.1 and pressure_bar=2 disagree"),
    "target-1e6.csv": ("target_angle_deg,tip_y_mm\n1e6,5\n", "target_angle_deg=1e+06: expected a target angle > 0 and <= 3600 deg"),
    "angle-1e6.csv": ("pressure_mpa,total_angle_deg\n0.1,1e6\n", "total_angle_deg=1e+06: expected a measured angle from -3600 to 3600 deg"),
    "sd-1e-300.csv": ("pressure_mpa,total_angle_deg,total_angle_sd_deg\n0.1,50,1e-300\n", "total_angle_sd_deg=1e-300: expected a standard deviation >= 1e-06 deg"),
    "underscore.csv": ("pressure_mpa,total_angle_deg\n0.1,5_0\n", "total_angle_deg='5_0': expected a number"),
}


@pytest.mark.parametrize("name", list(MEASUREMENTS))
def test_measurement_files_that_contradict_themselves_or_leave_the_model_are_refused(capsys, places, name):
    text, needle = MEASUREMENTS[name]
    path = Path(places["tmp"]) / name
    path.write_text(text)
    line = one_line_error(capsys, ["fit", str(path)], places)
    assert needle in line and name in line
    assert "RuntimeWarning" not in line and "CasADi" not in line


def test_one_pressure_in_two_units_that_agree_is_taken(capsys, places):
    path = Path(places["tmp"]) / "agree.csv"
    path.write_text("pressure_mpa,pressure_kpa,total_angle_deg\n0.1,100,50\n0.12,,70\n")
    assert main(["fit", str(path), "--free", "E", "--json"]) == EXIT_OK
    assert strict_json(capsys.readouterr().out)


RESUME = ["sweep", "--pressure", "0:0.2:5", "--resume", "--out", "s.csv", "--no-progress", "--no-compile"]


def _edit_line(path: Path, k: int, old: str, new: str) -> None:
    lines = path.read_text().split("\n")
    assert old in lines[k], lines[k]
    lines[k] = lines[k].replace(old, new, 1)
    path.write_text("\n".join(lines))


def _swap_rows(path: Path) -> None:
    lines = path.read_text().split("\n")
    lines[2], lines[3] = lines[3], lines[2]
    path.write_text("\n".join(lines))


def _edit_plan(path: Path) -> None:
    """The plan is in the study file beside the rows (FILE.study.json): a grid value edited, its hash left."""
    meta = path.with_name(path.stem + ".study.json")
    data = json.loads(meta.read_text())
    assert data["identity"]["plan"]["axes"]["pressure"] == [0.0, 0.05, 0.1, 0.15, 0.2]
    data["identity"]["plan"]["axes"]["pressure"][-1] = 0.3
    meta.write_text(json.dumps(data, indent=1))


def _move_tip(path: Path) -> None:
    """Row 2's tip_x_mm moved by 3 mm, everything else as written."""
    lines = path.read_text().split("\n")
    header, cells = lines[0].split(","), lines[2].split(",")
    k = header.index("tip_x_mm")
    cells[k] = repr(float(cells[k]) - 3.0)
    lines[2] = ",".join(cells)
    path.write_text("\n".join(lines))


# line 0 of the CSV holds the column names; line k holds row k
LIES = {
    "edited-pressure": (lambda p: _edit_line(p, 3, "0.1,", "0.123456,"), "row 3 has pressure_mpa=0.123456 where the plan has 0.1"),
    "nan-result": (lambda p: _edit_line(p, 2, ",newton,29.224099507465084,", ",newton,nan,"), "row 2 has a total_angle_deg cell that is neither a finite number nor empty"),
    "swapped-rows": (_swap_rows, "row 2 has pressure_mpa=0.1 where the plan has 0.05"),
    "edited-plan-same-hash": (_edit_plan, "was edited"),
    "total-not-the-sum": (lambda p: _edit_line(p, 2, "29.224", "39.224"), "row 2 has total_angle_deg=39.224"),
    "moved-tip": (_move_tip, "where its angles put it at"),
}


@pytest.mark.parametrize("lie", list(LIES))
def test_a_resumed_study_never_keeps_a_damaged_row(capsys, places, lie):
    assert main(RESUME) == EXIT_OK
    capsys.readouterr()
    path = Path(places["tmp"]) / "s.csv"
    edit, needle = LIES[lie]
    edit(path)
    before = path.read_bytes()
    line = one_line_error(capsys, RESUME, places)
    assert needle in line and "s.csv" in line
    assert path.read_bytes() == before  # the file is left as it is


def test_a_resumed_study_whose_rows_are_right_goes_on(capsys, places):
    assert main(RESUME) == EXIT_OK
    capsys.readouterr()
    assert main([*RESUME, "--json"]) == EXIT_OK
    data = strict_json(capsys.readouterr().out)
    assert data["study"]["resumed_from_row"] == 5 and data["counts"]["ok"] == 5


@pytest.mark.skipif(not hasattr(os, "mkfifo") or not os.path.exists("/dev/full"), reason="needs FIFOs and /dev/full")
@pytest.mark.parametrize("target", ["/dev/full", "/dev/zero", "fifo"])
def test_a_study_file_that_is_a_device_or_fifo_is_one_line_no_hang(capsys, places, target):
    tmp = Path(places["tmp"])
    if target == "fifo":
        os.mkfifo(tmp / "pipe")
        target = str(tmp / "pipe")
    (tmp / "s.csv").symlink_to(target)
    line = one_line_error(capsys, RESUME, places)
    assert "'s.csv'" in line or "s.csv:" in line
    assert "not a regular file" in line or "FIFO" in line


def _api_round2():
    from esba.analysis.path_analysis import column_buckling_load
    from esba.calibration.fit import FitError, fit, predict
    from esba.calibration.measurements import MeasurementError, load_measurements, measurements_from_rows
    from esba.calibration.uncertainty import UncertaintyError, draw_samples, ellipse, parse_sigma, propagate, resolve_sigmas
    from esba.infra.errors import InputError
    from esba.model.generated import load_model
    from esba.model.scene import MAIN_JOB, SceneError, load_scene
    from esba.paths.loading import history
    from esba.paths.problem import PathError, PathProblem
    from esba.statics.batch import BatchOptionsError, solve_arrays
    from esba.statics.equilibrium import SolverOptionsError, solve
    from esba.studies.sweep import SweepError, plan_sweep

    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=10%")])
    data = measurements_from_rows("rows", [("row 1", {"pressure_mpa": 0.1, "total_angle_deg": 60.0})])
    result = lambda: solve(MAIN_JOB)  # noqa: E731
    problem = lambda: PathProblem.from_scene(MAIN_JOB.replace(pressure=0.0), "pressure")  # noqa: E731
    nan = float("nan")
    return [
        ("propagate(r, None)", lambda: propagate(result(), None), UncertaintyError, "sigmas=None: expected a list of Sigma"),
        ("resolve_sigmas(None, ...)", lambda: resolve_sigmas(None, [parse_sigma("E=1")]), UncertaintyError, "scene=None: expected an esba.model.scene.Scene"),
        ("resolve_sigmas(s, 'E=1')", lambda: resolve_sigmas(MAIN_JOB, "E=1"), UncertaintyError, "specs='E=1': expected a list of SigmaSpec"),
        ("draw_samples(s, -5, 0)", lambda: draw_samples(sig, -5, 0), UncertaintyError, "samples=-5: expected a whole number from 1 to 1000000"),
        ("draw_samples(s, 10**12, 0)", lambda: draw_samples(sig, 10**12, 0), UncertaintyError, "samples=1000000000000"),
        ("draw_samples(s, 10, -1)", lambda: draw_samples(sig, 10, -1), UncertaintyError, "seed=-1"),
        ("ellipse('cov')", lambda: ellipse("cov"), UncertaintyError, "cov='cov': expected a square array"),
        ("ellipse(not PSD)", lambda: ellipse(np.diag([1.0, -1.0])), UncertaintyError, "cov has a negative eigenvalue"),
        ("ellipse(3 x 3)", lambda: ellipse(np.eye(3)), UncertaintyError, "expected a 2 x 2 covariance"),
        ("ellipse(nan)", lambda: ellipse(np.diag([nan, 1.0])), UncertaintyError, "not a finite number"),
        ("history(p, th, lam, 'abc')", lambda: history(problem(), [0.0] * 3, 0.0, "abc"), PathError, "values='abc': expected a list"),
        ("history(None, ...)", lambda: history(None, [0.0] * 3, 0.0, [1.0]), PathError, "problem=None: expected a PathProblem"),
        ("history(p, [nan]*3, ...)", lambda: history(problem(), [nan] * 3, 0.0, [0.1]), PathError, "theta0 has shape (3,): expected 3 finite angles"),
        ("column_buckling_load(segments=0)", lambda: column_buckling_load(segments=0), SceneError, "segments=0: expected a whole number from 1 to 256"),
        ("column_buckling_load(segments=2.5)", lambda: column_buckling_load(segments=2.5), SceneError, "segments=2.5"),
        ("column_buckling_load(segments=10**6)", lambda: column_buckling_load(segments=10**6), SceneError, "segments=1000000"),
        ("fit(d, free=None)", lambda: fit(data, free=None), FitError, "free=None: expected names of parameters"),
        ("predict(d, negative variance)", lambda: predict(data, {"E": 0.54}, [[-1.0]]), FitError, "covariance has a negative eigenvalue"),
        ("predict(None)", lambda: predict(None), FitError, "data=None"),
        ("load_measurements(None)", lambda: load_measurements(None), MeasurementError, "measurement file None: expected the path"),
        ("load_scene(None)", lambda: load_scene(None), SceneError, "scene file None: expected the path of a TOML scene file"),
        ("plan_sweep(pressure='abc')", lambda: plan_sweep(MAIN_JOB, pressure="abc"), SweepError, "pressure: 'abc': expected start:stop:count"),
        ("plan_sweep(pressure=[None])", lambda: plan_sweep(MAIN_JOB, pressure=[None]), SweepError, "pressure=[None]: expected one or more finite numbers"),
        ("solve_arrays(model, {})", lambda: solve_arrays(load_model(3), {}), BatchOptionsError, "values: missing parameter(s) L, r1, r2, d, rho and 5 more"),
        ("solve_arrays(model, P=nan)", lambda: solve_arrays(load_model(3), {**MAIN_JOB.parameters(0.1), "P": [nan]}), BatchOptionsError, "P[0] is not a finite number"),
        ("solve_arrays(None, {})", lambda: solve_arrays(None, {}), BatchOptionsError, "model=None: expected a Model"),
        ("with_parameters(scene, None)", lambda: __import__("esba.analysis.sensitivity", fromlist=["x"]).with_parameters(MAIN_JOB, None), InputError, "values=None: expected a mapping"),
        ("compare(None, None)", lambda: __import__("esba.calibration.uncertainty", fromlist=["x"]).compare(None, None), UncertaintyError, "compare(NoneType, NoneType): expected a Propagation"),
        ("solve_scenes(None)", lambda: __import__("esba.statics.batch", fromlist=["x"]).solve_scenes(None), BatchOptionsError, "scenes=None: expected a list of Scene"),
        ("horizontal_payload_sweep(segments=2.5)", lambda: __import__("esba.figures.paper", fromlist=["x"]).horizontal_payload_sweep([1.0], segments=2.5), SceneError, "segments=2.5: expected a whole number"),
        ("sensitivities(r, ['E', 'E'])", lambda: __import__("esba.analysis.sensitivity", fromlist=["x"]).sensitivities(result(), ["E", "E"]), InputError, "parameters: E given twice"),
        ("solve(theta0=[1e308]*3)", lambda: solve(MAIN_JOB, theta0=[1e308] * 3), SolverOptionsError, "theta0=[1e+308, 1e+308, 1e+308]: expected 3 angles (rad) with |angle| <= 1000"),
    ]


API2 = _api_round2()


@pytest.mark.parametrize("case", API2, ids=[c[0] for c in API2])
def test_python_api_raises_esba_errors_second_round(case):
    _, call, error, needle = case
    with pytest.raises(error) as info:
        call()
    message = str(info.value)
    assert needle in message and "\n" not in message and len(message) < 300
    assert type(info.value).__module__.split(".")[0] == "esba"


def test_plan_sweep_takes_what_the_cli_takes():
    from esba.model.scene import MAIN_JOB
    from esba.studies.sweep import parse_values, plan_sweep

    assert plan_sweep(MAIN_JOB, pressure="0:0.3:4").axes["pressure"] == parse_values("0:0.3:4") == [0.0, 0.1, 0.2, 0.3]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (a device whose writes fail: disk full)")
@pytest.mark.parametrize(
    "argv, name",
    [
        (["path", "--to", "0.15", "--out", "p.csv", "--no-plot"], "p.csv"),
        (["path", "--to", "0.15", "--plot", "p.png", "--no-out"], "p.png"),
        (["audit", "--out", "a.md"], "a.md"),
        (["validate", "--out", "v.md"], "v.md"),
        (["solve", "--plot", "s.png"], "s.png"),
        (["sweep", "--pressure", "0.1", "--plot", "w.png", "--no-progress"], "w.png"),
    ],
)
def test_a_full_disk_names_the_file_in_every_command(capsys, places, argv, name):
    (Path(places["tmp"]) / name).symlink_to("/dev/full")
    line = one_line_error(capsys, argv, places, code=EXIT_FAILED)
    assert line == f"esba: error: {name}: cannot write (No space left on device)"


def test_no_runtime_warning_and_no_value_the_user_did_not_give(capsys, places):
    assert main(["stiffness", "--pressure", "0", "--json"]) == EXIT_OK
    out, err = capsys.readouterr()
    tangent = strict_json(out)["tangent"]
    assert tangent["vertical_n_per_m"] is None and tangent["horizontal_n_per_m"] > 0
    assert "RuntimeWarning" not in err and "inf" not in err
    assert main(["stiffness", "--pressure", "0"]) == EXIT_OK
    out, err = capsys.readouterr()
    assert "vertical unbounded" in out and "inf N/m" not in out and "Warning" not in err
    line = one_line_error(capsys, ["path", "--to", "1e-320", "--no-plot", "--no-out"], places)
    assert "'1e-320': below the smallest normal double" in line
    assert main(["pressure", "--total-angle", "-90"]) == EXIT_FAILED  # not reachable: said, naming no pressure the user did not give
    out, err = capsys.readouterr()
    assert "pressure=-" not in err and "Warning" not in err and "the target is not reachable" in err


def test_check_of_a_missing_page_says_missing(capsys, places):
    assert main(["audit", "--check"]) == EXIT_FAILED
    out, err = capsys.readouterr()
    assert "is MISSING" in out and "STALE" not in out and "derivations.md is missing" in err
    assert main(["docs", "--check", "validation", "--dir", places["tmp"]]) == EXIT_FAILED
    out, err = capsys.readouterr()
    assert "missing" in out and "stale" not in out.lower()


def test_closed_stdout_ends_without_a_traceback(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    p = subprocess.run(f"{sys.executable} -m esba.cli solve --no-plot >&-", shell=True, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == EXIT_OK, p.stderr
    assert "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines()[-1] == "esba: warning: standard output was closed: what the command printed is lost"


@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="needs a C compiler")
def test_damaged_compiled_library_with_a_matching_checksum_does_not_crash(tmp_path):
    """Truncated, and its checksum record rewritten to match: the checksum cannot tell. A child
    process loads it first and dies of the bus error instead of esba."""
    import hashlib

    env = {**os.environ, "ESBA_CACHE_DIR": str(tmp_path / "cache")}
    argv = [sys.executable, "-m", "esba.cli", "sweep", "--pressure", "0:0.2:600", "--no-progress", "--json"]
    first = subprocess.run(argv, env=env, capture_output=True, text=True, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    lib = next((tmp_path / "cache" / "compiled").glob("esba_batch_*.so"))
    data = lib.read_bytes()[:4096]
    lib.write_bytes(data)
    cache.record_path(lib).write_text(json.dumps({"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}))
    assert cache.damage(lib) is None  # the checksum is satisfied
    again = subprocess.run(argv, env=env, capture_output=True, text=True, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    lines = again.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"esba: compiled batch solver {lib} is damaged (") and "building it again" in lines[0]
    assert "Traceback" not in again.stderr
    assert strict_json(again.stdout)["counts"]["ok"] == 600
    assert cache.library_damage(lib) is None  # rebuilt


def test_a_path_of_a_million_steps_is_bounded_or_said_up_front(capsys, places):
    line = one_line_error(capsys, ["path", "-n", "16", "--to", "1", "--max-steps", "1000000", "--ds-max", "1e-6", "--no-plot", "--no-out"], places)
    assert "--max-steps 1000000 at n = 16: the branches could hold about 3.2 GiB of points (limit 2 GiB): at most" in line
    assert main(["path", "--to", "0.13", "--max-steps", "200000", "--no-plot", "--no-out"]) == EXIT_OK
    err = capsys.readouterr().err
    assert err.startswith("esba: note: --max-steps 200000 at n = 3: up to 0.3 GiB of points and minutes of work")


def _cells(line: str, k: int, value: str) -> str:
    cells = line.split(",")
    cells[k] = value
    return ",".join(cells)


@pytest.mark.parametrize(
    "edit, needle",
    [
        (lambda line: _cells(line, -2, "nan"), "sample row 1 has a cell that is not a finite number (as written, an empty cell is no value)"),
        (lambda line: _cells(line, -3, "0.1"), "sample row 1 is ok but its total_angle_rad=0.1 is not the sum of its angles"),
        (lambda line: _cells(line, 1, "0.6"), "its samples are not the ones drawn again from seed 0"),
    ],
    ids=["nan-tip", "total-not-the-sum", "edited-sample"],
)
def test_a_resumed_monte_carlo_never_keeps_a_damaged_sample_row(capsys, places, edit, needle):
    argv = ["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20", "--mc-out", "mc.csv"]
    assert main(argv) == EXIT_OK
    capsys.readouterr()
    path = Path(places["tmp"]) / "mc.csv"
    lines = path.read_text().split("\n")  # line 0: the column names, line 1: sample row 1
    assert lines[1].split(",")[2] == "ok"
    lines[1] = edit(lines[1])
    path.write_text("\n".join(lines))
    line = one_line_error(capsys, [*argv, "--resume"], places)
    assert "mc.csv" in line and needle in line
