"""The fast paths give the answers of the reference paths: the O(n) structured solves against
dense LAPACK, the compiled ramp against the adaptive path trace, the NumPy centre-line against the
generated Function, the combined state call against the single ones, and the BLAS thread setting is
restored after each call.
"""

from __future__ import annotations

import numpy as np
import pytest

from esba.model import structured
from esba.model.generated import load_model
from esba.model.scene import Payload, Scene
from esba.solvers.newton import run_natural
from esba.statics.equilibrium import SolverOptions, solve
from tests.tolerances import BATCH_THETA_ATOL, KERNEL_ATOL, KERNEL_RTOL

EFFECT_SETS = [
    ("air,axial,radial,fibres,payload", (Payload(2.0, 90.0),), False),
    ("air,axial,radial,fibres,payload:2,gravity", (Payload(3.0, 150.0, 0.6), Payload(2.0, 60.0, 1.0)), True),
    ("air,axial,radial,fibres,gravity", (), True),
    ("air,axial,radial", (), False),
]


def _hessians(n: int):
    rng = np.random.default_rng(n)
    for effects, payloads, gravity in EFFECT_SETS:
        model = load_model(n, effects)
        scene = Scene(segments=n, payloads=payloads, gravity=gravity, pressure=0.15, fibres="fibres" in effects)
        pv = model.param_vector(scene.parameters(0.15))
        lower = model.lower_bounds(scene.parameters(0.15))[0]
        for _ in range(6):
            theta = np.maximum(rng.normal(size=n) * 0.5, 0.5 * lower)
            yield model.hessian(theta, pv)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8, 16])
def test_structured_solve_and_inertia_match_dense_lapack(n):
    rng = np.random.default_rng(100 + n)
    for h in _hessians(n):
        assert structured.check_structure(h)  # every generated Hessian has the structure
        b = rng.normal(size=n)
        np.testing.assert_allclose(structured.solve(h, b), np.linalg.solve(h, b), rtol=1e-9, atol=1e-12 * np.max(np.abs(b)))
        eig = np.linalg.eigvalsh(h)
        assert structured.inertia(h)[0] == int(np.sum(eig < 0))


def test_structured_inertia_of_indefinite_matrices():
    """Random matrices with the structure and any inertia: the pivots count the negative eigenvalues."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(1, 12))
        c = np.concatenate([[0.0], rng.normal(size=n - 1)])
        e = rng.normal(size=n) * 3
        j, k = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        h = np.diag(e) + c[np.maximum(j, k)]
        eig = np.linalg.eigvalsh(h)
        if np.min(np.abs(eig)) < 1e-6:
            continue
        assert structured.inertia(h)[0] == int(np.sum(eig < 0))
        np.testing.assert_allclose(h @ structured.solve(h, np.ones(n)), np.ones(n), atol=1e-8 * np.linalg.cond(h))


SCENES = [
    Scene(payloads=(Payload(2.0, 90.0),), segments=n) for n in (1, 2, 3, 5, 8)
] + [
    Scene(pressure=p, payloads=(Payload(f, om),)) for p in (0.05, 0.12, 0.165, 0.172, 0.2) for f, om in ((2.0, 90.0), (1.0, 0.0), (3.0, 135.0))
] + [
    Scene(payloads=(Payload(2.0, float(om)),)) for om in (0, 60, 118, 120, 121, 125, 180, 270)
] + [
    Scene(pressure=1e-3, payloads=(Payload(10.0, 180.0),)),  # snaps: the fast ramp must hand it on
    Scene(pressure=0.0, payloads=(Payload(3.3, 180.0),), segments=4),  # buckles at a branch point
    Scene(pressure=0.1, payloads=(Payload(1.0, 45.0, 0.5), Payload(2.0, 120.0)), gravity=True, segments=6),
    Scene(target_angle_deg=200.0, payloads=(Payload(0.5, 90.0),), segments=16),
]


@pytest.mark.parametrize("scene", SCENES, ids=lambda s: s.describe())
def test_fast_ramp_gives_the_reference_answer(scene):
    fast = solve(scene)
    reference = solve(scene, SolverOptions(fast=False))
    assert fast.ok == reference.ok and fast.stability == reference.stability
    np.testing.assert_allclose(fast.theta, reference.theta, atol=BATCH_THETA_ATOL)
    assert len(fast.jumps) == len(reference.jumps) and len(fast.branch_points) == len(reference.branch_points)
    for a, b in zip(fast.jumps, reference.jumps):
        assert a.lam == pytest.approx(b.lam, rel=1e-8)


def test_the_fast_ramp_refuses_a_snap_and_a_buckling():
    for scene in (Scene(pressure=1e-3, payloads=(Payload(10.0, 180.0),)), Scene(pressure=0.0, payloads=(Payload(3.3, 180.0),), segments=4)):
        model = scene.model()
        p0 = model.param_vector(scene.parameters(scene.pressure, load_factor=0.0))
        dp = model.param_vector(scene.parameters(scene.pressure)) - p0
        start = solve(scene.replace(payloads=(Payload(0.0, 180.0),))).theta
        run = run_natural(model, start, p0, dp, 1.0)
        assert not run.accepted() and "not positive definite" in run.why_not()


@pytest.mark.parametrize("n", [1, 3, 7, 16])
def test_numpy_centreline_matches_the_generated_function(n):
    model = load_model(n)
    theta = np.random.default_rng(n).normal(size=n)
    theta[0] = 0.0  # a straight segment among bent ones
    s = np.linspace(0.0, 1.0, 4 * n + 1)
    generated = np.asarray(model["centreline"].map(len(s))(theta, 135.0, s.reshape(1, -1))).T
    np.testing.assert_allclose(model.centreline(theta, 135.0, len(s)), generated, rtol=KERNEL_RTOL, atol=KERNEL_ATOL)


def test_state_matches_the_single_calls():
    scene = SCENES[0].replace(segments=5)
    model = scene.model()
    pv = model.param_vector(scene.parameters(0.1))
    theta = np.linspace(-0.1, 0.4, 5)
    st = model.state(theta, pv)
    assert st["energy"] == pytest.approx(model.energy(theta, pv), rel=KERNEL_RTOL)
    assert st["terms"] == pytest.approx(model.energy_terms(theta, pv), rel=KERNEL_RTOL)
    np.testing.assert_allclose(st["gradient"], model.gradient(theta, pv), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
    np.testing.assert_allclose(st["hessian"], model.hessian(theta, pv), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)
    np.testing.assert_allclose(st["tip"], model.tip(theta, 135.0), rtol=KERNEL_RTOL, atol=KERNEL_ATOL)


def test_blas_threads_are_restored_after_a_solve():
    from threadpoolctl import threadpool_info

    before = [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"]
    solve(SCENES[0])
    assert [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"] == before


def test_help_imports_no_numerics():
    """``esba --help`` and every ``esba CMD --help`` start without CasADi, NumPy or SymPy."""
    import subprocess
    import sys

    from esba.cli import COMMANDS, build_parser

    names = sorted(build_parser()._subparsers._group_actions[0].choices)  # type: ignore[union-attr]
    assert len(names) == len(COMMANDS)
    script = (
        "import sys, contextlib, io\n"
        "from esba.cli import main\n"
        "for argv in [['--help']] + [[c, '--help'] for c in sys.argv[1:]]:\n"
        "    with contextlib.redirect_stdout(io.StringIO()):\n"
        "        try:\n"
        "            main(argv)\n"
        "        except SystemExit:\n"
        "            pass\n"
        "print(sorted(m for m in ('casadi', 'numpy', 'sympy', 'scipy', 'matplotlib') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", script, *names], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
