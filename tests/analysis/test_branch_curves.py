"""Branch-point curves of the in-plane state in two parameters (esba.analysis.branch_curves): every point
a sideways branch point (B5's Hessian checks), the branch points of one-parameter paths on them
(esba path --3d, esba map --3d, docs/maps.md), and the points where two of a path's branch points merge."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from esba.analysis.branch_curves import BranchCurve, branch_point_curves, branch_points_at, check_symmetric
from esba.analysis.folds import Plane, fold_curves_csv
from esba.model.scene import Payload, Scene
from esba.paths.problem import PathError
from esba.statics.spatial import newton3d
from tests.tolerances import PATHS_AGREE_REL

MAPS_MD = Path(__file__).resolve().parents[2] / "docs" / "maps.md"
#: A horizontal tip payload in the bending plane, the eccentric section's stiffnesses (esba section).
SCENE = Scene(pressure=0.0, payloads=(Payload(1.0, 90.0),))
BOX = ((0.05, 0.3), (0.2, 3.0))


@pytest.fixture(scope="module")
def pf():
    plane = Plane.from_scene3d(SCENE, "pressure", "payload")
    return plane, branch_point_curves(plane, *BOX)


def _engine(scene: Scene, param: str, to: float) -> list[float]:
    """The branch points esba path --3d finds on the path of ``param`` from the scene to ``to``."""
    from esba.analysis.path3d import analyse3d

    path = analyse3d(scene, param, to, switch=False, loading=False)
    return sorted(s.lam for s in path.main.branch_points if s.status == "converged")


def test_every_point_of_the_curve_is_a_sideways_branch_point_of_the_in_plane_state(pf):
    """B5's checks at points of the curve: g = 0 (its sideways part exactly), the 3-D Hessian singular
    with a null vector that bends sideways and twists but leaves theta alone, the in-plane block
    positive definite; and across the curve the in-plane state's sideways eigenvalue changes sign."""
    plane, curves = pf
    (curve,) = curves
    assert isinstance(curve, BranchCurve) and len(curve) > 50 and curve.stop_reason == "left the map"
    n = plane.segments
    model = plane.px.model
    for k in np.linspace(0, len(curve) - 1, 12).astype(int):
        q, x, y = curve.theta[k], float(curve.xs[k]), float(curve.ys[k])
        vals = plane.values(x, y)
        g, h = model.gradient(q, vals), model.hessian(q, vals)
        assert np.all(q[n:] == 0.0) and np.all(g[n:] == 0.0) and np.abs(g).max() < 1e-9
        w, V = np.linalg.eigh(0.5 * (h + h.T))
        scale = np.abs(w).max()
        assert abs(w[0]) < 1e-10 * scale and w[1] > 1e-6 * scale  # one zero eigenvalue, the rest positive
        assert np.abs(V[:n, 0]).max() < 1e-10  # the mode: sideways bend and twist only, coupled (lateral-torsional;
        assert np.abs(V[n : 2 * n, 0]).max() > 1e-3 and np.abs(V[2 * n :, 0]).max() > 0.5  # mostly twist: GJ << EI_side)
        assert np.linalg.eigvalsh(h[:n, :n])[0] > 0 and curve.stable[k]
        # the in-plane state just left and right of the curve (along x): stable on one side, not on the other
        mins = []
        for dx in (-1e-4, 1e-4):
            shifted = plane.values(x + dx, y)
            qs, ok, _ = newton3d(model, shifted, q)
            assert ok and np.all(qs[n:] == 0.0)
            mins.append(np.linalg.eigvalsh(model.hessian(qs, shifted))[0])
        assert mins[0] * mins[1] < 0, (x, y, mins)


def _maps_md_eccentric() -> dict[float, list[float]]:
    """docs/maps.md's 3-D pressure paths, eccentric section: the branch points (MPa) by payload."""
    text = MAPS_MD.read_text().split("### The pressure paths in 3-D")[1]
    out = {}
    for force, cell in re.findall(r"^\| ([\d.]+) \| [^|]+ \| ([^|]+) \|$", text, flags=re.M):
        out[float(force)] = sorted(float(v) for v in re.findall(r"branch point at ([\d.]+)", cell))
    return out


def test_the_branch_points_of_pressure_and_payload_paths_lie_on_the_curve(pf):
    from esba.analysis.maps3d import Plane3D, path_points

    plane, curves = pf
    documented = _maps_md_eccentric()
    forces = (0.5, 1.0, 2.0)
    map_plane = Plane3D.from_scene(SCENE, "pressure", "payload")
    points, _ = path_points(map_plane, (0.05, 0.3), (0.5, 2.0), lines=4, axes=("x",))  # payloads 0.5, 1, 1.5, 2 N
    for force in forces:
        on_curve = branch_points_at(plane, curves, BOX, y=force)
        assert len(on_curve) == 2, (force, on_curve)
        engine = _engine(SCENE.replace(pressure=0.05, payloads=(Payload(force, 90.0),)), "pressure", 0.3)
        ramps = sorted(p.x for p in points if abs(p.y - force) < 1e-12 and p.kind == "branch point")
        for found in (engine, ramps):
            assert len(found) == 2 and np.allclose(found, on_curve, rtol=PATHS_AGREE_REL, atol=0), (force, found, on_curve)
        assert np.allclose(documented[force], on_curve, rtol=0, atol=0.51e-8), (force, documented[force], on_curve)
    # the payload paths (x = const) from no payload: their branch points too
    for pressure in (0.15, 0.2, 0.25):
        on_curve = branch_points_at(plane, curves, BOX, x=pressure)
        engine = [f for f in _engine(SCENE.replace(pressure=pressure, payloads=(Payload(0.0, 90.0),)), "payload", 3.0) if f >= BOX[1][0]]
        assert len(on_curve) >= 1 and len(engine) == len(on_curve), (pressure, engine, on_curve)
        assert np.allclose(engine, on_curve, rtol=PATHS_AGREE_REL, atol=0), (pressure, engine, on_curve)


def test_where_two_branch_points_of_a_path_merge(pf):
    """The curve's lowest payload: pressure paths just above it branch twice, just below not at all;
    its lowest pressure: likewise for payload paths."""
    plane, curves = pf
    (curve,) = curves
    kinds = {p.kind: p for p in curve.special}
    assert sorted(kinds) == ["two branch points of the x-path merge", "two branch points of the y-path merge"]
    assert all(p.status == "converged" for p in curve.special)
    low_f = kinds["two branch points of the x-path merge"]
    low_p = kinds["two branch points of the y-path merge"]
    assert low_f.y <= np.min(curve.ys) + 1e-12 and low_p.x <= np.min(curve.xs) + 1e-12
    assert low_f.to_dict(plane.names)["label"] == "BBx" and low_p.label == "BBy"
    for force, count in ((low_f.y + 0.01, 2), (low_f.y - 0.01, 0)):
        assert len(branch_points_at(plane, curves, BOX, y=force)) == count
        assert len(_engine(SCENE.replace(pressure=0.05, payloads=(Payload(force, 90.0),)), "pressure", 0.3)) == count, force
    for pressure, count in ((low_p.x + 0.002, 2), (low_p.x - 0.002, 0)):
        near = [f for f in branch_points_at(plane, curves, BOX, x=pressure) if f < 2.5]
        engine = [f for f in _engine(SCENE.replace(pressure=pressure, payloads=(Payload(0.0, 90.0),)), "payload", 2.5) if f >= BOX[1][0]]
        assert len(near) == len(engine) == count, (pressure, near, engine)


def test_a_branch_point_curve_file(pf):
    _, curves = pf
    header = fold_curves_csv(curves).splitlines()[0].split(",")
    assert {"theta1_deg", "psi1_deg", "tau1_deg", "inplane_min_eig", "loses_stability", "special"} <= set(header)
    d = curves[0].to_dict()
    assert d["special_points"] and all(p["sideways_share"] == pytest.approx(1.0, abs=1e-12) for p in d["special_points"])


def test_loads_off_the_plane_and_planar_planes_are_refused_in_one_line():
    tilted = Plane.from_scene3d(Scene(pressure=0.0, payloads=(Payload(1.0, 90.0, out_of_plane_deg=10.0),)), "pressure", "payload")
    with pytest.raises(PathError, match="leave the bending plane") as exc:
        check_symmetric(tilted, BOX)
    assert "\n" not in str(exc.value)
    beta = Plane.from_scene3d(SCENE, "pressure", "beta")
    with pytest.raises(PathError, match="leave the bending plane"):
        branch_point_curves(beta, (0.1, 0.2), (5.0, 10.0))
    with pytest.raises(PathError, match="the planar model's") as exc:
        branch_point_curves(Plane.from_scene(SCENE, "pressure", "payload"), *BOX)
    assert "\n" not in str(exc.value)


def test_where_the_branch_point_curve_meets_the_in_plane_fold_curve():
    """With a softer torsion (GJ = 1e4) the sideways branch points reach the bistable window: where the
    branch-point curve meets the in-plane fold curve the 3-D Hessian has two zero eigenvalues, one
    in-plane and one sideways, and the fold curve traced on its own passes through the point."""
    from esba.analysis.folds import fold_curves, folds_at

    plane = Plane.from_scene3d(Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),)), "pressure", "payload", {"EI_side": 4e5, "GJ": 1e4})
    box = ((0.1, 0.3), (0.5, 4.0))
    curves = branch_point_curves(plane, *box)
    meets = [p for c in curves for p in c.special if p.kind == "meets an in-plane fold"]
    assert len(meets) == 2 and all(p.status == "converged" and p.label == "FBP" for p in meets)
    folds = fold_curves(plane, *box)
    n = plane.segments
    model = plane.px.model
    for p in meets:
        h = model.hessian(p.theta, plane.values(p.x, p.y))
        scale = np.abs(h).max()
        assert abs(np.linalg.eigvalsh(h[:n, :n])[0]) < 1e-9 * scale and abs(np.linalg.eigvalsh(h[n:, n:])[0]) < 1e-9 * scale
        assert min(abs(f - p.x) for f in folds_at(plane, folds, box, y=p.y)) < 1e-8 * p.x
    # between the two meetings the in-plane state on the curve is unstable in the plane (past a fold)
    assert not all(c.stable.all() for c in curves)
