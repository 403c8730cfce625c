"""The result of a trace: a Branch, its special points, its eigenvalues on demand, its files."""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest

from esba.model.scene import Payload, Scene
from esba.paths.branch import LABELS, STOPS, branches_csv, write_branches
from esba.paths.continuation import PathError, trace
from esba.paths.problem import PathProblem
from esba.statics.equilibrium import solve


@pytest.fixture(scope="module")
def branch():
    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
    problem = PathProblem.from_scene(scene, "pressure")
    return problem, trace(problem, solve(scene).theta, 0.0, to=0.3)


def test_the_arrays_have_one_row_per_point(branch):
    _, b = branch
    m, n = len(b), b.theta.shape[1]
    assert b.lam.shape == (m,) and b.tip.shape == (m, 3) and b.morse.shape == (m,) and b.min_pivot.shape == (m,)
    assert b.kind[0] == "start" and b.stopped in STOPS and b.stop_reason
    assert np.all(np.diff(b.arclength) >= 0)
    assert b.eigenvalues.shape == (m, n)


def test_the_eigenvalues_computed_on_demand_are_the_hessians(branch):
    problem, b = branch
    for i in (0, len(b) // 2, len(b) - 1):
        h = problem.ghl(b.theta[i], b.lam[i])[1]
        np.testing.assert_allclose(b.eigenvalues[i], np.linalg.eigvalsh(h), rtol=1e-10, atol=1e-9)
    scale = np.max(np.abs(b.eigenvalues), axis=1)
    np.testing.assert_array_equal(b.morse, np.sum(b.eigenvalues < -1e-9 * scale[:, None], axis=1))
    # stable: Morse index 0 outside the critical band; the middle of the bistable range is unstable
    assert b.stable[0] and not b.stable.all()


def test_tips_are_the_generated_kinematics(branch):
    problem, b = branch
    for i in (0, len(b) - 1):
        np.testing.assert_allclose(b.tip[i], problem.tip(b.theta[i], b.lam[i]), atol=1e-12)


def test_special_points_sit_in_the_arrays(branch):
    _, b = branch
    assert [s.kind for s in b.special] == ["fold", "fold"] and [s.label for s in b.special] == [LABELS["fold"]] * 2
    for s in b.special:
        assert b.kind[s.index] == "fold" and b.lam[s.index] == s.lam
        assert s.total_angle_deg == pytest.approx(math.degrees(float(np.sum(s.theta))))
    assert b.folds == b.special and b.branch_points == ()


def test_json_and_csv_hold_every_point_and_no_nan(branch, tmp_path):
    _, b = branch
    d = b.to_dict()
    text = json.dumps(d, allow_nan=False)
    assert len(d["lambda"]) == len(b) and len(d["eigenvalues"]) == len(b) and len(json.loads(text)["special_points"]) == 2
    rows = list(csv.DictReader(io.StringIO(branches_csv([b]))))
    assert len(rows) == len(b) and {"eigenvalue1", "theta1_deg", "morse_index", "stable"} <= set(rows[0])
    path = write_branches([b], tmp_path / "b.json", extra={"scene": "x"})
    assert json.loads(path.read_text())["scene"] == "x"
    with pytest.raises(PathError, match="ending in .csv or .json"):
        write_branches([b], tmp_path / "b.txt")
