"""Kernels generated to C and called through ctypes give CasADi's own answers, and a kernel that
cannot be compiled runs in CasADi's interpreter."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from esba.infra.errors import InputError
from esba.model.generated import load_model
from esba.model.scene import Payload, Scene
from esba.paths.problem import PathProblem
from esba.solvers.native import Kernel, compiler
from esba.solvers.newton import bordered_function, bordered_layout, critical_function


@pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, gcc, cc) on this machine")
@pytest.mark.parametrize("n", [1, 3])
def test_compiled_kernels_equal_casadis_evaluation(n):
    model = load_model(n)
    problem = PathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(2.0, 90.0),), segments=n), "pressure")
    fun = bordered_function(model, 1)
    compiled, interpreted = Kernel(fun, "always", n), Kernel(fun, "never", n)
    assert compiled.compiled and not interpreted.compiled
    rng = np.random.default_rng(n)
    for _ in range(5):
        x = np.concatenate([rng.uniform(-0.2, 0.6, n), [0.12]])
        c = rng.normal(size=n + 1)
        z = np.concatenate([x, c, [float(c @ x), 1e-9], problem.p0, problem.dp])
        np.testing.assert_allclose(compiled(z), interpreted(z), rtol=1e-12, atol=1e-12)
    lay = bordered_layout(n, 1)
    assert lay["u"].stop == fun.nnz_out(0)


def test_the_critical_mode_is_the_eigenpair_nearest_zero():
    """Next to a fold (where the dips check asks for it) inverse iteration finds the eigenvalue that
    crosses zero and its slope along the branch."""
    from esba.paths.continuation import trace
    from esba.statics.equilibrium import solve

    scene = Scene(pressure=0.0, payloads=(Payload(2.0, 90.0),), segments=4)
    problem = PathProblem.from_scene(scene, "pressure")
    b = trace(problem, solve(scene).theta, 0.0, to=0.3)
    i = b.folds[0].index - 1  # the point before the first fold
    theta, lam = b.theta[i], b.lam[i]
    n = 4
    t = np.r_[b.theta[i + 1] - theta, b.lam[i + 1] - lam]
    k = Kernel(critical_function(load_model(n)), "never", n)
    out = k(np.concatenate([theta, [lam], np.ones(n), t, problem.p0, problem.dp]))
    e, v = np.linalg.eigh(problem.ghl(theta, lam)[1])
    j = int(np.argmin(np.abs(e)))
    assert out[n] == pytest.approx(e[j], rel=1e-8)
    assert abs(float(out[:n] @ v[:, j])) == pytest.approx(1.0, abs=1e-8)
    # its slope: the change of that eigenvalue to the next point, to first order
    e2 = np.linalg.eigvalsh(problem.ghl(b.theta[i + 1], b.lam[i + 1])[1])
    assert out[n + 1] == pytest.approx(e2[np.argmin(np.abs(e2 - e[j]))] - e[j], rel=0.2)


def test_kernels_take_one_vector_in_and_out():
    z = ca.SX.sym("z", 2)
    with pytest.raises(InputError, match="one input and one output"):
        Kernel(ca.Function("f", [z, ca.SX.sym("w")], [z]))
    with pytest.raises(InputError, match="compile='sometimes'"):
        Kernel(ca.Function("f", [z], [z]), "sometimes")


def test_a_kernel_with_after_runs_interpreted_then_compiles_at_that_run(tmp_path, monkeypatch):
    """``after``: interpreted (no compiler time) for the first runs, compiled at the after-th run;
    decided by the count, never by time, and the same numbers to round-off."""
    import casadi as ca

    from esba.solvers.native import Kernel, compiler

    if compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("ESBA_CACHE_DIR", str(tmp_path))
    z = ca.SX.sym("z", 2)
    fun = ca.Function("k_after", [z], [ca.vertcat(ca.sin(z[0]) * z[1], z[0] + z[1])])
    k = Kernel(fun, "auto", 3, after=3)
    x = np.array([0.3, 2.0])
    first = [k(x) for _ in range(2)]
    assert not k.compiled
    third = k(x)
    assert k.compiled and k(x) is not None
    np.testing.assert_allclose(third, first[0], rtol=1e-15, atol=0)
    again = Kernel(fun, "auto", 3, after=2)  # the next process loads it from the cache at its 2nd run
    again(x)
    assert not again.compiled
    again(x)
    assert again.compiled and len(list(tmp_path.rglob("*.so"))) == 1
    k.count(5)  # counting a compiled kernel's runs does nothing
