"""The command line: esba map: fold curves, cusps, the figure, the grid check, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from esba.cli import EXIT_OK, EXIT_USAGE, main
from esba.cli.map import _MAP_PARAMETERS
from esba.paths.problem import PARAMETERS
from tests.figures import drawn


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_parser_knows_every_parameter():
    assert set(_MAP_PARAMETERS) == set(PARAMETERS)


def test_omega_payload_map(capsys, tmp_path, monkeypatch):
    saved = drawn.record_saved(monkeypatch)
    out_json, fig = tmp_path / "m.json", tmp_path / "m.png"
    code, out, err = run(
        capsys, "map", "--x", "omega:110:135", "--y", "payload:0:4", "--target-angle", "90", "--check-grid", "4",
        "--resolution", "41", "--history-lines", "5", "--out", str(out_json), "--plot", str(fig), "--json",
    )
    assert code == EXIT_OK, err
    data = json.loads(out)
    assert data["summary"]["cusp"] == 1 and data["summary"]["branch point of the y-path"] == 1
    (cusp,) = [p for p in data["special_points"] if p["kind"] == "cusp"]
    assert 122.0 < cusp["omega1"] < 122.4 and cusp["status"] == "converged"
    assert data["check_grid"]["agrees"] and data["check_grid"]["k"] == 4
    written = json.loads(out_json.read_text())
    assert written["fold_curves"][0]["points"] == data["fold_curves"][0]["points"]
    assert written["check_grid"] == data["check_grid"] and written["scene"] == data["scene"]  # the file holds what --json prints
    # the figure shows the fold curve of the file, the cusp and the jumps
    (ax,) = drawn.axes(saved[fig.resolve()])
    assert ax.get_xlabel() == "payload direction from the vertical (deg)" and ax.get_ylabel() == "payload magnitude (N)"
    (curve,) = drawn.starting(ax, "fold curve 0")
    x = np.asarray(curve.get_xdata(), dtype=float)
    assert np.nanmin(x) == pytest.approx(data["fold_curves"][0]["x_range"][0])
    (star,) = drawn.starting(ax, "cusp")
    assert star.get_xdata()[0] == pytest.approx(cusp["omega1"])
    assert len(drawn.starting(ax, "jump, payload direction from the vertical rising")[0].get_xdata()) == len(data["jumps"]["loading"])


def test_map_table(capsys, tmp_path):
    code, out, err = run(capsys, "map", "--x", "pressure:0.1:0.25", "--y", "payload:1:3", "--pressure", "0", "--no-out", "--no-plot", "--resolution", "21", "--history-lines", "3")
    assert code == EXIT_OK, err
    assert "CP  cusp" in out and "payload1 = 1.6452" in out and "stable states: 1 to 2" in out


@pytest.mark.parametrize(
    "args, words",
    [
        (["--x", "omega:110", "--y", "payload:0:4"], "PARAM:FROM:TO"),
        (["--x", "omega:120:110", "--y", "payload:0:4"], "FROM < TO"),
        (["--x", "speed:0:1", "--y", "payload:0:4"], "unknown parameter"),
        (["--x", "payload:0:4", "--y", "payload1:0:4"], "same model parameter"),
        (["--x", "pressure:-1:0.2", "--y", "payload:0:4"], "outside the parameter's range"),
        (["--x", "omega2:0:90", "--y", "payload:0:4"], "1 payload"),
        (["--x", "pressure:0:1e300", "--y", "payload:0:4"], "at most 50000 MPa wide"),
        (["--x", "omega:nan:3", "--y", "payload:0:4"], "finite FROM < TO"),
        (["--x", "omega:110:135", "--y", "payload:0:4", "--check-grid", "0"], "--check-grid"),
    ],
)
def test_bad_input(capsys, args, words):
    code, out, err = run(capsys, "map", *args, "--no-out", "--no-plot")
    assert code == EXIT_USAGE and words in err and err.count("\n") == 1, err


@pytest.mark.parametrize(
    "args, words",
    [
        (["--envelope-pressure", "0.3"], "needs both"),
        (["--envelope-pressure", "0.3", "--envelope-payload", "-2"], "max_payload=-2"),
        (["--envelope-pressure", "0.3", "--envelope-payload", "2", "--objective", "angle"], "stiffness objective"),
        (["--envelope-pressure", "0.3", "--envelope-payload", "2", "--fold-margin", "-1"], "margin=-1"),
        (["--envelope-pressure", "0.3", "--envelope-payload", "2", "--envelope-at", "0"], "at=0"),
    ],
)
def test_design_envelope_bad_input(capsys, args, words):
    code, out, err = run(capsys, "design", *args)
    assert code == EXIT_USAGE and words in err and err.count("\n") == 1, err
