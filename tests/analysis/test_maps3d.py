"""3-D stability maps (esba.analysis.maps3d): the planar restriction, branch points, the brute-force cell check."""

from __future__ import annotations

import math

import numpy as np
import pytest

from esba.analysis.maps3d import (
    CLASSES, Map3DError, Plane3D, check_grid3d, follow, path_points, principal, stability_map3d,
)
from esba.model.scene import Payload, Scene

#: A section stiff out of the plane: the Table 1 actuator then stays in its plane up to 4 N (docs/3d.md).
STIFF = {"EI_side": 4e5, "GJ": 1e5}
LOADED = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),))


@pytest.fixture(scope="module")
def stiff_plane():
    return Plane3D.from_scene(LOADED, "pressure", "payload", STIFF)


@pytest.fixture(scope="module")
def soft_plane():
    """The gripper's plane: pressure by the payload's direction around the actuator, 0.5 N, the eccentric section's stiffnesses."""
    return Plane3D.from_scene(Scene(pressure=0.0, payloads=(Payload(0.5, 90.0),)), "pressure", "around")


def _planar_folds(payload: float) -> list[float]:
    """The folds of the planar pressure path at ``payload`` (the planar path engine)."""
    from esba.analysis.folds import Plane
    from esba.paths.continuation import trace
    from esba.statics.equilibrium import solve

    plane = Plane.from_scene(LOADED, "pressure", "payload")
    branch = trace(plane.along_x(payload), solve(plane.scene_at(0.1, payload)).theta, 0.1, to=0.25)
    return sorted(float(p.lam) for p in branch.special if p.kind == "fold")


def test_for_in_plane_loads_the_folds_of_the_3d_map_are_the_planar_ones(stiff_plane):
    points, notes = path_points(stiff_plane, (0.1, 0.25), (2.0, 2.5), lines=2)
    assert notes == []
    for payload in (2.0, 2.5):
        found = sorted(p.x for p in points if p.along == "x" and p.y == payload)
        assert all(p.kind == "fold" and p.sideways_share < 1e-20 and abs(p.twist_deg) < 1e-15 for p in points if p.along == "x")
        planar = _planar_folds(payload)
        assert len(found) == len(planar) == 2
        assert np.max(np.abs(np.array(found) - planar)) < 1e-10
    # along the payload (y) the principal state of this section does not fold up to 2.5 N
    assert [p for p in points if p.along == "y"] == []


def test_the_branch_point_of_the_history_is_statics_first_instability(soft_plane):
    """At an in-plane load the principal state loses stability at a branch point: a Hessian zero whose
    mode is sideways only, at the load :func:`esba.statics.spatial.first_instability` finds."""
    from esba.statics.spatial import first_instability

    vals = soft_plane.values(0.17, 0.0)
    out = principal(soft_plane, vals, 0.5)
    assert out.kind == "branch point" and out.critical < 0.5 and out.sideways_share == pytest.approx(1.0, abs=1e-12)
    model = soft_plane.model
    vals0 = dict(vals, F1=0.0)
    from esba.analysis.maps3d import _unloaded

    ref = first_instability(model, vals0, "F1", _unloaded(soft_plane, vals0), top=0.5, steps=20)
    assert ref is not None and ref[0] == pytest.approx(out.critical, abs=1e-9)
    w = np.linalg.eigvalsh(model.hessian(out.q_critical, dict(vals, F1=out.critical)))
    assert abs(w[0]) < 1e-8 * np.abs(w).max()
    assert np.all(out.q_critical[model.n:] == 0.0)  # the state is in the plane
    # past it the state that flips is stable out of the plane (a brute-force state there is sideways)
    from esba.analysis.maps3d import brute_states

    states = brute_states(soft_plane, dict(vals, F1=0.5))
    assert states and all(np.abs(s[model.n:]).max() > 1e-3 for s in states)


def test_a_small_tilt_out_of_the_plane_turns_the_branch_point_into_a_smooth_twist(soft_plane):
    """The imperfect pitchfork: tilted by 5 degrees the payload twists the finger past the bound
    without a loss of stability (class 'twisted'), and in the plane it flips (class 'flips')."""
    from esba.analysis.maps3d import classify

    for around, expected in ((0.0, "flips"), (5.0, "twisted")):
        vals = soft_plane.values(0.17, around)
        out = principal(soft_plane, vals, 0.5, (0.5,))
        assert CLASSES[classify(soft_plane, out, 0.5)] == expected


def test_the_gripper_map_agrees_with_brute_force_cell_by_cell(soft_plane):
    smap = stability_map3d(soft_plane, (0.05, 0.25), (0.0, 180.0), resolution=7, lines=0)
    assert set(np.unique(smap.classes)) >= {0, 1}
    check = check_grid3d(smap, 2)
    assert check.agrees, check.to_dict()
    assert check.near_mismatches == 0
    assert all(c[4] >= 1 for c in check.cells)  # the multistart finds a stable state in every cell
    # the twist bounds located between the raster's cells are at the bound
    twist = [b for b in smap.boundaries if b.kind == "twist bound"]
    assert twist and all(abs(abs(b.twist_deg) - 10.0) < 1e-6 for b in twist)


@pytest.mark.slow
def test_the_gripper_map_agrees_with_brute_force_on_a_fuller_grid(soft_plane):
    smap = stability_map3d(soft_plane, (0.05, 0.25), (0.0, 180.0), resolution=21, lines=0)
    check = check_grid3d(smap, 6)
    assert check.agrees, check.to_dict()


@pytest.mark.slow
def test_an_off_plane_payload_map_agrees_with_brute_force():
    plane = Plane3D.from_scene(Scene(pressure=0.15, payloads=(Payload(1.0, 90.0),)), "beta", "payload", {"EI_side": 4e5, "GJ": 1e4})
    smap = stability_map3d(plane, (0.0, 60.0), (0.0, 1.5), resolution=11, lines=3)
    check = check_grid3d(smap, 4)
    assert check.agrees, check.to_dict()


def test_following_a_path_backwards_finds_the_lower_fold(stiff_plane):
    vals = stiff_plane.values(0.25, 2.0)
    out = principal(stiff_plane, vals, 2.0, (2.0,))
    down = follow(stiff_plane, vals, "P", 0.25, 0.1, out.states[2.0])
    assert down.kind == "fold" and down.critical == pytest.approx(_planar_folds(2.0)[0], abs=1e-10)


@pytest.mark.parametrize(
    "x, y, scene, words",
    [
        ("pressure", "pressure", LOADED, "two different"),
        ("omega", "around", LOADED, "cannot be mapped"),
        ("spin", "payload", LOADED, "unknown 3-D map parameter"),
        ("pressure", "payload", Scene(pressure=0.0, payloads=(Payload(1.0, 90.0), Payload(1.0, 90.0, 0.5))), "exactly one payload"),
    ],
)
def test_bad_planes_are_refused_in_one_line(x, y, scene, words):
    with pytest.raises(Map3DError, match=words) as exc:
        Plane3D.from_scene(scene, x, y, STIFF)
    assert "\n" not in str(exc.value)


def test_bad_ranges_are_refused_in_one_line(stiff_plane):
    for name, lo, hi, words in (("pressure", -0.1, 0.2, ">= 0"), ("beta", 0.0, 120.0, "-90 to 90"), ("at", 0.0, 1.0, r"\(0, 1\]")):
        with pytest.raises(Map3DError, match=words):
            stiff_plane.check_range("--x", name, lo, hi)
    with pytest.raises(Map3DError, match="max-twist"):
        Plane3D.from_scene(LOADED, "pressure", "payload", STIFF, max_twist_deg=math.inf)
