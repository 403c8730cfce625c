"""Fold curves in two parameters: cusps and fold/branch-point meetings located to 1e-8, the folds of
docs/paths.md on the curves, and stability maps checked cell by cell against brute force."""

from __future__ import annotations

import csv
import io
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from esba.analysis.folds import FoldOptions, Plane, fold_curves, fold_curves_csv, folds_at, write_fold_curves
from esba.analysis.maps import check_grid, stability_map, stable_states
from esba.infra.errors import RunError
from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.paths.continuation import trace
from esba.statics.equilibrium import solve
from tests.tolerances import LOCATE_RTOL

DOCS = Path(__file__).resolve().parents[2] / "docs" / "paths.md"
PF_BOX = ((0.1, 0.25), (1.0, 3.0))
OF_BOX = ((110.0, 135.0), (0.0, 4.0))


@pytest.fixture(scope="module")
def pf():
    plane = Plane.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload")
    return plane, fold_curves(plane, *PF_BOX)


@pytest.fixture(scope="module")
def of():
    plane = Plane.from_scene(MAIN_JOB, "omega", "payload")
    return plane, fold_curves(plane, *OF_BOX)


def _residuals(plane, p):
    g, h, gx, gy, hv, hvt, _, _ = plane.terms(p.theta, p.x, p.y, p.vector)
    return g, hv, h, gx, gy, hvt


def test_cusp_of_the_bistable_window_under_a_horizontal_payload(pf):
    plane, curves = pf
    (curve,) = curves
    (cusp,) = curve.cusps
    assert cusp.status == "converged"
    assert cusp.y == pytest.approx(1.645, abs=1e-3)  # docs/paths.md: 1.645 N by bisection to 1e-3 N
    g, hv, h, _, _, hvt = _residuals(plane, cusp)
    assert np.max(np.abs(g)) < 1e-9 and np.max(np.abs(hv)) < 1e-9 * np.max(np.abs(h))
    # the cusp test, the fold's quadratic coefficient, vanishes there (against its size along the curve)
    assert abs(cusp.vector @ hvt @ cusp.vector) < 1e-8 * np.max(np.abs(curve.cusp_test))
    # the same cusp from a trace with other steps: located to a relative 1e-8
    other = fold_curves(plane, *PF_BOX, options=FoldOptions(ds=0.013, ds_max=0.027))
    (again,) = other[0].cusps
    assert again.x == pytest.approx(cusp.x, rel=LOCATE_RTOL) and again.y == pytest.approx(cusp.y, rel=LOCATE_RTOL)
    # the two folds of a pressure path merge there: two above the cusp's payload, none just below
    assert len(folds_at(plane, curves, PF_BOX, y=cusp.y + 0.01)) == 2
    assert len(folds_at(plane, curves, PF_BOX, y=cusp.y - 0.01)) == 0


def _paths_md_folds():
    text = DOCS.read_text()
    table = text.split("### The bistable range opens with the payload")[1].split("###")[0]
    rows = re.findall(r"^\| ([\d.]+) \| ([\d.]+), ([\d.]+) \| [\d.]+ \|$", table, flags=re.M)
    by_payload = {float(f): sorted([float(a), float(b)]) for f, a, b in rows}
    up, down = re.search(r"the branch folds at \*\*([\d.]+) deg\*\*.*?and at \*\*([\d.]+) deg\*\*", text, flags=re.S).groups()
    cusp = float(re.search(r"a cusp\) at a payload of \*\*([\d.]+) N\*\*", text).group(1))
    return by_payload, sorted([float(up), float(down)]), cusp


def test_the_folds_of_docs_paths_lie_on_the_fold_curves(pf, of):
    by_payload, omega_folds, cusp = _paths_md_folds()
    plane, curves = pf
    # the pressure folds of the n = 3 table (5 decimals): payloads 2, 2.5, 3 N (the n table repeats 2 N)
    checked = 0
    for force, folds in by_payload.items():
        if PF_BOX[1][0] <= force <= PF_BOX[1][1]:
            on_curve = folds_at(plane, curves, PF_BOX, y=force)
            assert np.allclose(on_curve, folds, atol=0.51e-5), (force, on_curve, folds)
            checked += 1
    assert checked >= 3
    assert curves[0].cusps[0].y == pytest.approx(cusp, abs=1e-3)
    plane, curves = of
    on_curve = [f for f in folds_at(plane, curves, OF_BOX, y=2.0) if 115 < f < 125]
    assert np.allclose(on_curve, omega_folds, atol=0.51e-3), (on_curve, omega_folds)


def test_near_122_deg_a_payload_path_folds_twice_or_not_at_all(of):
    plane, curves = of
    kinds = sorted(p.kind for c in curves for p in c.special)
    assert kinds == ["branch point of the y-path", "cusp"]
    bp = next(p for c in curves for p in c.special if p.kind == "branch point of the y-path")
    cusp = next(p for c in curves for p in c.cusps)
    assert bp.status == cusp.status == "converged"
    assert 122.0 < bp.x < cusp.x < 122.4  # a window of a tenth of a degree
    # at the branch point the fold curve is tangent to the payload path: omega is extremal there
    _, _, _, _, gy, _ = _residuals(plane, bp)
    assert abs(bp.vector @ gy) < 1e-9 * np.linalg.norm(gy)
    # the payload path from F = 0 (the engine's trace): two folds inside the window, none outside,
    # and its folds lie on the fold curve
    for omega, count in ((bp.x + 0.03, 2), (bp.x - 0.03, 0), (cusp.x + 0.03, 0)):
        problem = plane.along_y(omega)
        theta = solve(plane.scene_at(omega, 0.0)).theta
        b = trace(problem, theta, 0.0, to=4.0)
        folds = [f.lam for f in b.folds]
        assert len(folds) == count, (omega, folds)
        on_curve = folds_at(plane, curves, OF_BOX, x=omega)
        for f in folds:
            assert min(abs(f - c) for c in on_curve) <= 1e-8 * f


@pytest.mark.parametrize(
    "scene, x, xr, y, yr",
    [
        (Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", (0.1, 0.25), "payload", (1.0, 3.0)),
        (MAIN_JOB, "omega", (110.0, 135.0), "payload", (0.0, 4.0)),
        (Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", (0.05, 0.25), "omega", (60.0, 160.0)),
    ],
    ids=["pressure-payload", "omega-payload", "pressure-omega"],
)
def test_map_agrees_with_brute_force_on_a_grid(scene, x, xr, y, yr):
    smap = stability_map(Plane.from_scene(scene, x, y), xr, yr, resolution=41, history_lines=0)
    check = check_grid(smap, 9)
    counts = [c[3] for c in check.cells]
    assert max(counts) == 2 and min(counts) == 1  # the grid sees both regions
    assert check.mismatches == 0 and check.near_mismatches == 0, [c for c in check.cells if c[2] != c[3]]


def test_stable_states_are_stationary_minima_and_distinct():
    plane = Plane.from_scene(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload")
    states = stable_states(plane, 0.168, 2.5)
    assert len(states) == 2
    problem = plane.along_x(2.5)
    for theta in states:
        g, h, _ = problem.ghl(theta, 0.168)
        assert np.max(np.abs(g)) <= 1e-9 and np.linalg.eigvalsh(h)[0] > 0
    assert np.max(np.abs(states[0] - states[1])) > 0.1


def test_jump_lines_are_the_folds_of_the_history(pf):
    plane = pf[0]
    smap = stability_map(plane, *PF_BOX, resolution=21, history_lines=5)
    (up,) = [p[0] for p in smap.jumps["loading"] if p[1] == 2.0]
    (down,) = [p[0] for p in smap.jumps["unloading"] if p[1] == 2.0]
    folds = folds_at(plane, smap.curves, PF_BOX, y=2.0)
    assert up == pytest.approx(folds[1], rel=LOCATE_RTOL) and down == pytest.approx(folds[0], rel=LOCATE_RTOL)


def test_fold_curve_files(pf, tmp_path):
    _, curves = pf
    text = fold_curves_csv(curves)
    head = text.splitlines()[0].split(",")
    assert head[:4] == ["curve", "point", "pressure", "payload1"]
    (cusp_row,) = [r for r in csv.DictReader(io.StringIO(text)) if r["special"] == "cusp"]
    vector = curves[0].cusps[0].vector
    assert [float(cusp_row[f"v{i + 1}"]) for i in range(len(vector))] == pytest.approx(vector, rel=1e-11)  # the critical vector, as in the JSON
    import json

    path = write_fold_curves(curves, tmp_path / "f.json", {"what": "test"})
    data = json.loads(path.read_text())
    assert data["what"] == "test" and data["fold_curves"][0]["points"] == len(curves[0])
    (cusp,) = [p for p in data["fold_curves"][0]["special_points"] if p["kind"] == "cusp"]
    assert cusp["payload1"] == curves[0].cusps[0].y


def test_a_plane_of_one_parameter_twice_is_refused():
    from esba.paths.problem import PathError

    with pytest.raises(PathError, match="same model parameter"):
        Plane.from_scene(MAIN_JOB, "payload", "payload1")


def test_design_plane_figure_shows_each_design():
    from esba.design.envelope import Envelope, design_plane
    from esba.figures.maps import design_plane_figure
    from tests.figures import drawn

    dp = design_plane(None, Envelope(0.3, 2.5, margin=0.05), [0.8, 1.5, 3.0], [0.0, 2.0], optimum=None)
    assert len(dp.state) == 6 and dp.count("clear") == 1 and dp.count("snaps") >= 3  # r2 = 0.8, d = 0 is clear
    (ax,) = drawn.axes(design_plane_figure(dp))
    shown = sum(len(c.get_offsets()) for c in ax.collections if c.get_label() and not c.get_label().startswith("_"))
    assert shown == 6 and ax.get_xlabel() == "chamber radius r2 (mm)" and ax.get_ylabel() == "eccentric distance d (mm)"


def test_counting_in_blocks_gives_the_same_regions(pf):
    from esba.analysis import maps

    plane, curves = pf
    smap = stability_map(plane, *PF_BOX, resolution=31, history_lines=0)
    xs, ys = np.meshgrid(smap.grid_x, smap.grid_y)
    whole = smap.count(xs, ys)
    saved = maps.CROSSING_BLOCK
    try:
        maps.CROSSING_BLOCK = 500  # a few points per block
        assert np.array_equal(smap.count(xs, ys), whole)
    finally:
        maps.CROSSING_BLOCK = saved


def test_no_segment_spans_a_cusp():
    # esba map --x E:0.4:0.7 --y payload:0:4 --pressure 0.17: the cusp (payload 1.659058 N) lies
    # between two traced points (the lowest at 1.6591976 N); across it the fold's side flips, and
    # a segment spanning it gave both tips the same sign: -1 stable states just above the cusp
    from esba.analysis import maps

    plane = Plane.from_scene(replace(MAIN_JOB, pressure=0.17, target_angle_deg=None), "E", "payload")
    smap = stability_map(plane, (0.4, 0.7), (0.0, 4.0), resolution=11, history_lines=0)
    (cusp,) = smap.curves[0].cusps
    assert cusp.y < float(np.min(smap.curves[0].ys))  # the case: the cusp is inside a traced segment
    xs, ys = np.meshgrid([0.45, 0.5, cusp.x - 1e-4], [1.6591, 1.6592, 1.6595, 1.66])
    crossings = maps.count_at(smap.curves, smap.spans, smap.reference, xs, ys)  # without the brute-force safety net
    brute = [len(stable_states(plane, float(x), float(y))) for x, y in zip(xs.ravel(), ys.ravel())]
    assert brute == [1] * xs.size and crossings.tolist() == brute
    assert not smap.recounted and int(np.min(smap.counts)) >= 1


def test_an_impossible_count_is_recounted_by_brute_force(pf):
    from esba.analysis import maps

    plane, curves = pf
    smap = stability_map(plane, *PF_BOX, resolution=11, history_lines=0)
    wrong = replace(smap, reference=(*smap.reference[:2], smap.reference[2] - 2))  # every count 2 too low
    x, y = np.array([0.12, 0.168]), np.array([1.2, 2.5])  # 1 and 2 stable states (test_stable_states_...)
    assert maps.count_at(curves, smap.spans, wrong.reference, x, y).tolist() == [-1, 0]
    assert wrong.count(x, y).tolist() == [1, 0]  # the impossible -1 recounted (1 state), the possible 0 left
    saved = maps.MAX_RECOUNTS
    try:
        maps.MAX_RECOUNTS = 0  # bounded: more impossible counts than this are an error, not a long brute force
        with pytest.raises(RunError, match="below 0 stable states at 1 points"):
            wrong.count(x, y)
    finally:
        maps.MAX_RECOUNTS = saved
