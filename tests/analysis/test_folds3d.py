"""Fold curves of the 3-D model in two parameters (esba.analysis.folds on a Plane.from_scene3d): the
planar curves for in-plane loads, and the folds an off-plane payload unfolds the sideways branch
point into, checked against the folds of one-parameter paths (esba path --3d, esba map --3d)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from esba.analysis.folds import Plane, fold_curves, fold_curves_csv, folds_at
from esba.model.scene import Payload, Scene
from esba.paths.problem import PathError
from tests.tolerances import PATHS_AGREE_REL, REDUCES_TO_PLANAR

MAPS_MD = Path(__file__).resolve().parents[2] / "docs" / "maps.md"
#: A section stiff out of the plane: the Table 1 actuator then stays in its plane up to 4 N (docs/3d.md).
STIFF = {"EI_side": 4e5, "GJ": 1e5}
LOADED = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))
PF_BOX = ((0.1, 0.25), (1.0, 3.0))
#: The horizontal payload tilted 15 deg out of the bending plane, the eccentric section's stiffnesses.
TILT = 15.0
TILTED = Scene(pressure=0.0, payloads=(Payload(1.0, 90.0, out_of_plane_deg=TILT),))
TILT_BOX = ((0.05, 0.3), (0.0, 3.0))


@pytest.fixture(scope="module")
def planar():
    plane = Plane.from_scene(LOADED, "pressure", "payload")
    return plane, fold_curves(plane, *PF_BOX)


@pytest.fixture(scope="module")
def spatial():
    plane = Plane.from_scene3d(LOADED, "pressure", "payload", STIFF)
    return plane, fold_curves(plane, *PF_BOX)


@pytest.fixture(scope="module")
def tilted():
    plane = Plane.from_scene3d(TILTED, "pressure", "payload")
    return plane, fold_curves(plane, *TILT_BOX)


def _maps_md():
    """docs/maps.md's first map: the cusp (P, F) and the folds of the pressure paths by payload."""
    text = MAPS_MD.read_text()
    cusp = re.search(r"^\| cusp \| ([\d.]+) \| ([\d.]+) \|", text, flags=re.M).groups()
    table = text.split("| payload (N) | folds on the curve (MPa) |")[1].split("\n\n")[0]
    folds = {float(f): [float(a), float(b)] for f, a, b in re.findall(r"^\| ([\d.]+) \| ([\d.]+), ([\d.]+) \|$", table, flags=re.M)}
    return tuple(map(float, cusp)), folds


def test_for_in_plane_loads_the_3d_fold_curves_are_the_planar_ones(planar, spatial):
    p2, c2 = planar
    p3, c3 = spatial
    n = p3.segments
    assert p3.spatial and not p2.spatial and p3.n == 3 * n == 3 * p2.n
    assert len(c3) == len(c2) == 1
    # the folds of the in-plane state: no sideways bend or twist, a mode in the plane
    assert np.abs(c3[0].theta[:, n:]).max() < 1e-12 and np.abs(c3[0].v[:, n:]).max() < 1e-12
    assert np.abs(c3[0].twist_deg).max() < 1e-10
    # the same special points, to 1e-10
    s2, s3 = c2[0].special, c3[0].special
    assert [p.kind for p in s3] == [p.kind for p in s2] == ["branch point of the y-path", "cusp"]
    for a, b in zip(s2, s3):
        assert b.status == "converged"
        assert abs(a.x - b.x) < REDUCES_TO_PLANAR and abs(a.y - b.y) < REDUCES_TO_PLANAR
        assert np.abs(a.theta - b.theta[:n]).max() < REDUCES_TO_PLANAR
    # the folds of the pressure paths (y = const) and of the payload paths (x = const), to 1e-10
    for y in (1.7, 2.0, 2.5, 3.0):
        f2, f3 = folds_at(p2, c2, PF_BOX, y=y), folds_at(p3, c3, PF_BOX, y=y)
        assert len(f2) == len(f3) == 2 and np.max(np.abs(np.subtract(f2, f3))) < REDUCES_TO_PLANAR, (y, f2, f3)
    for x in (0.15, 0.17, 0.2):
        f2, f3 = folds_at(p2, c2, PF_BOX, x=x), folds_at(p3, c3, PF_BOX, x=x)
        assert len(f2) == len(f3) >= 1 and np.max(np.abs(np.subtract(f2, f3))) < REDUCES_TO_PLANAR, (x, f2, f3)


def test_the_3d_cusp_and_folds_are_the_numbers_of_docs_maps(spatial):
    (cusp_p, cusp_f), folds = _maps_md()
    plane, curves = spatial
    (cusp,) = curves[0].cusps
    assert cusp.x == pytest.approx(cusp_p, abs=0.51e-10) and cusp.y == pytest.approx(cusp_f, abs=0.51e-9)
    assert set(folds) >= {2.0, 2.5, 3.0}
    for force, expected in folds.items():
        assert np.allclose(folds_at(plane, curves, PF_BOX, y=force), expected, rtol=0, atol=0.51e-8), force


def test_a_3d_fold_curve_file_names_the_sideways_bend_and_twist(spatial):
    _, curves = spatial
    header = fold_curves_csv(curves).splitlines()[0].split(",")
    assert {"theta1_deg", "psi1_deg", "tau3_deg", "twist_deg", "cusp_test", "stable_fold"} <= set(header)
    d = curves[0].to_dict()
    assert {"psi_deg", "tau_deg", "twist_deg", "sideways_share"} <= set(d["special_points"][0]) and "twist_deg" in d["curve"][0]


def test_an_off_plane_payload_unfolds_the_branch_point_into_folds_that_paths_find(tilted):
    """Tilted 15 deg out of the plane, the horizontal payload twists the finger; at low pressure the
    pressure path folds twice (rising, falling) where in the plane it had a sideways branch point:
    the fold curve's crossings of y = const are the folds that esba path --3d (the path engine) and
    esba map --3d (maps3d's ramp and the extended system by central differences) find, to 1e-6."""
    from esba.analysis.maps3d import Plane3D, path_points
    from esba.analysis.path3d import analyse3d

    plane, curves = tilted
    (curve,) = curves
    (cusp,) = curve.cusps
    assert cusp.status == "converged" and 0.06 < cusp.x < 0.1 and 1.0 < cusp.y < 2.0
    n = plane.segments
    assert np.min(np.abs(curve.twist_deg)) > 10.0  # the folds of a twisted state
    shares = np.sum(curve.v[:, n:] ** 2, axis=1)
    assert np.all(shares > 0.5)  # ... whose mode is mostly sideways
    forces = (1.8, 2.4, 3.0)
    map_plane = Plane3D.from_scene(TILTED, "pressure", "payload")
    points, _ = path_points(map_plane, TILT_BOX[0], (1.8, 3.0), lines=3, axes=("x",))
    for force in forces:
        on_curve = folds_at(plane, curves, TILT_BOX, y=force)
        assert len(on_curve) == 2, (force, on_curve)
        path = analyse3d(Scene(pressure=0.05, payloads=(Payload(force, 90.0, out_of_plane_deg=TILT),)), "pressure", 0.3,
                         switch=False, loading=False)
        engine = sorted(s.lam for s in path.main.special if s.kind == "fold" and s.status == "converged")
        ramps = sorted(p.x for p in points if abs(p.y - force) < 1e-12 and p.kind == "sideways fold")
        for found in (engine, ramps):
            assert len(found) == 2 and np.allclose(found, on_curve, rtol=PATHS_AGREE_REL, atol=0), (force, found, on_curve)
    # below the cusp the pressure path does not fold
    path = analyse3d(Scene(pressure=0.05, payloads=(Payload(cusp.y - 0.1, 90.0, out_of_plane_deg=TILT),)), "pressure", 0.3,
                     switch=False, loading=False)
    assert not path.main.folds and folds_at(plane, curves, TILT_BOX, y=cusp.y - 0.1) == []


def test_the_tilted_fold_in_another_plane_of_parameters(tilted):
    """The fold at (P, F) of the (pressure, payload) plane lies on the fold curve of the (beta, payload)
    plane through that pressure, at beta = 15 deg: the same fold, continued in other parameters."""
    plane, curves = tilted
    force = 2.4
    p_fold = folds_at(plane, curves, TILT_BOX, y=force)[1]
    other = Plane.from_scene3d(TILTED.replace(pressure=p_fold), "beta", "payload")
    box = ((5.0, 25.0), (1.5, 3.0))
    found = folds_at(other, fold_curves(other, *box), box, x=TILT)
    assert min(abs(f - force) for f in found) < 1e-8 * force, found


def test_a_3d_plane_of_one_parameter_twice_or_an_unknown_one_is_refused():
    with pytest.raises(PathError, match="same model parameter") as exc:
        Plane.from_scene3d(LOADED, "payload", "payload1", STIFF)
    assert "\n" not in str(exc.value)
    with pytest.raises(PathError, match="a 3-D path follows") as exc:
        Plane.from_scene3d(LOADED, "pressure", "r2", STIFF)
    assert "\n" not in str(exc.value)
