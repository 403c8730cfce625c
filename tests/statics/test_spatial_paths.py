"""3-D paths on the planar continuation engine (esba.statics.spatial_paths, esba.analysis.path3d):
B5 as a branch point, switching onto the sideways branches, the paper's actuator flipping sideways."""

from __future__ import annotations

import numpy as np
import pytest

from esba.analysis.path3d import analyse3d, path3d_table
from esba.analysis.rod3d import PRANDTL, lateral_torsional_load, richardson, rod_values
from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.model.spatial import load_model3d
from esba.paths.continuation import bifurcating_branches, trace
from esba.paths.problem import PathError
from esba.statics.spatial import newton3d
from esba.statics.spatial_paths import SpatialPathProblem


def _b5_branch(n: int, top: float = 6.0):
    model = load_model3d(n, "rod,payload")
    problem = SpatialPathProblem.from_values(model, rod_values(EI=1e6, F=0.0, Omega=np.pi / 2), "payload")
    return problem, trace(problem, np.zeros(model.size), 0.0, to=top)


def test_b5_is_a_sideways_pitchfork_located_by_the_engine_where_brent_finds_the_singular_hessian():
    n = 3  # a committed model: nothing to generate
    problem, branch = _b5_branch(n)
    assert branch.stopped == "bound" and branch.lam[-1] == 6.0
    (bp,) = branch.branch_points
    assert not branch.folds
    assert bp.status == "converged" and bp.bifurcation == "pitchfork" and (bp.morse_before, bp.morse_after) == (0, 1)
    assert abs(bp.lam - lateral_torsional_load(n).load) < 1e-6 * bp.lam
    assert np.abs(bp.eigenvector[:n]).max() < 1e-8  # the mode is sideways bend and twist only
    assert np.abs(bp.theta[n:]).max() == 0.0  # on the in-plane branch
    sides = bifurcating_branches(problem, bp, bounds=(0.0, 6.0))
    assert len(sides) == 2
    for b in sides:
        assert b.stopped == "bound" and b.lam[-1] == 6.0 and bool(np.all(b.stable[len(b) // 2:]))
        q = b.theta[-1]
        assert np.abs(q[n:]).max() > 0.1  # flipped sideways and twisted
        vals = rod_values(EI=1e6, F=6.0, Omega=np.pi / 2)
        assert np.abs(problem.model.gradient(q, vals)).max() < 1e-9
    z = sorted(float(b.tip[-1, 2]) for b in sides)
    assert z[0] < 0 < z[1] and abs(z[0] + z[1]) < 1e-8  # mirror images


@pytest.mark.slow
def test_b5_prandtl_from_the_engine_within_half_a_percent():
    loads = [_b5_branch(n, 6.0)[1].branch_points[0].lam for n in (8, 16)]
    limit = richardson(*loads)
    assert abs(limit / PRANDTL - 1.0) < 0.005


@pytest.mark.slow
def test_the_paper_actuator_flips_sideways_past_a_branch_point_and_the_ramp_follows_it():
    r = analyse3d(MAIN_JOB, "payload", 2.0, start=0.0)
    (bp,) = r.main.branch_points
    assert 0.5 < bp.lam < 1.0 and bp.bifurcation == "pitchfork"
    d = r.to_dict(points=False)
    assert d["branches"][0]["special_points"][0]["mode"] == "sideways"
    labels = [b["label"] for b in d["branches"][1:]]
    assert sorted(labels) == ["BP1 sideways +z", "BP1 sideways -z"]
    up = r.loading[0]
    assert up.reached and not up.jumps and [s.lam for s in up.branch_points] == [bp.lam]
    assert abs(abs(float(np.sum(up.theta[3:6]))) - abs(float(np.sum(r.crossing[0].theta[-1][3:6])))) < 1e-6
    down = r.loading[1]  # back along the sideways branch to the branch point, then on along the in-plane branch
    assert down.reached and not down.jumps and [s.lam for s in down.branch_points] == pytest.approx([bp.lam], rel=1e-8)
    assert np.abs(down.theta[3:]).max() < 1e-8
    assert "branch point" in path3d_table(d)
    # the in-plane state past the branch point is unstable: the planar answer is not what the actuator does
    assert not r.main.stable[-1]


def test_a_3d_path_in_the_out_of_plane_angle_turns_the_tip_sideways():
    scene = Scene(pressure=0.1, payloads=(Payload(0.5, 0.0),))
    r = analyse3d(scene, "beta", 30.0, section={"EI_side": 4e5, "GJ": 1e6}, switch=False, loading=False)
    assert r.main.stopped == "bound" and r.main.lam[-1] == 30.0
    tips = r.main.tip
    assert tips[0, 2] == 0.0 and tips[-1, 2] > 0.1 and bool(np.all(np.diff(tips[:, 2]) > 0))


@pytest.mark.parametrize(
    "parameter, message",
    [("r2", "a 3-D path follows pressure"), ("payload2", "the scene has 1 payload"), ("bogus", "a 3-D path follows")],
)
def test_bad_3d_path_parameters_are_refused_in_one_line(parameter, message):
    with pytest.raises(PathError, match=message) as info:
        SpatialPathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(0.5, 90.0),)), parameter)
    assert "\n" not in str(info.value)


def test_a_path_problem_of_any_model_parameter_and_a_load_factor():
    model = load_model3d(3, "rod,payload")  # B5's model above
    vals = rod_values(EI=1.0, F=1.0)
    p = SpatialPathProblem.from_values(model, vals, "GJ")
    assert p.name == "GJ" and p.lam0 == 1.0
    p = SpatialPathProblem.from_values(model, vals, "load")
    q, ok, _ = newton3d(model, vals, np.zeros(9))
    assert ok
    g, h, gl = p.ghl(q, 1.0)
    assert np.abs(g).max() < 1e-10 and np.allclose(h, model.hessian(q, vals))
    with pytest.raises(PathError, match="no payload, moment or weight"):
        SpatialPathProblem.from_values(model, rod_values(EI=1.0, F=0.0), "load")


def test_natural_continuation_is_refused_for_a_3d_problem_in_one_line():
    from esba.paths.continuation import Natural, continuation

    model = load_model3d(3, "rod,payload")
    problem = SpatialPathProblem.from_values(model, rod_values(EI=1.0, F=0.0), "payload")
    with pytest.raises(PathError, match=r"Natural\(\) continuation is the planar model's"):
        continuation(problem, np.zeros(9), 0.0, to=1.0, algorithm=Natural())


def test_the_dense_critical_kernel_takes_the_parameters_of_its_call():
    """The kernels live in the problem's registry, which problems that differ only in p0 share (a
    dataclasses.replace: esba.analysis.folds.Plane's lines); the critical kernel (segments > 4) must
    evaluate at the call's p0 and dp, as the compiled one does."""
    from dataclasses import replace

    from esba.statics.spatial_paths import _Critical

    problem = SpatialPathProblem.from_scene(Scene(pressure=0.15, payloads=(Payload(1.0, 90.0),)), "pressure")
    other = replace(problem, p0=problem.p0 + 0.5 * (np.array(problem.model.parameters) == "F1"))  # the pressure path under 1.5 N
    assert other.registry is problem.registry
    n = problem.segments
    q = np.concatenate([np.full(n, 0.4), np.full(n, 0.01), np.full(n, 0.02)])
    v0, t = np.ones(3 * n), np.ones(3 * n + 1)
    for prob in (problem, other):
        z = np.concatenate([q, [0.15], v0, t, prob.p0, prob.dp])
        mine = _Critical(prob)(z)
        shared = _Critical(problem)(z)  # built for the first problem, called with the other's parameters
        assert np.allclose(shared, mine, rtol=1e-12, atol=1e-12)
        w = np.linalg.eigvalsh(prob.ghl(q, 0.15)[1])
        assert mine[3 * n] == pytest.approx(w[np.argmin(np.abs(w))], rel=1e-10)


@pytest.mark.parametrize("n", [2, 3])
def test_the_column_buckles_in_3d_at_the_planar_load_and_in_the_plane(n):
    # issue 26: the planar column's buckling load reproduced by the 3-D model (a section stiff sideways)
    from esba.paths.problem import PathProblem

    f_cr = 3.23742997 if n == 3 else None
    scene = Scene(pressure=0.0, payloads=(Payload(1.0, 180.0),), segments=n)
    planar = PathProblem.from_scene(scene, "payload")
    (p_bp,) = trace(planar, np.zeros(n), 1.0, to=6.0).branch_points
    spatial = SpatialPathProblem.from_scene(scene, "payload", {"EI_side": 4e5, "GJ": 1e6})
    (s_bp,) = trace(spatial, np.zeros(3 * n), 1.0, to=6.0).branch_points
    assert p_bp.status == s_bp.status == "converged"
    assert abs(s_bp.lam - p_bp.lam) <= 1e-10 * p_bp.lam
    assert np.abs(s_bp.eigenvector[n:]).max() < 1e-8  # the buckling mode lies in the bending plane
    if f_cr is not None:
        assert abs(s_bp.lam - f_cr) < 1e-7
