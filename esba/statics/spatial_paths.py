"""Paths of the spatial (3-D) model on the planar continuation engine (:mod:`esba.paths`).

A :class:`SpatialPathProblem` is what :class:`esba.paths.problem.PathProblem` is for the planar
model, for a :class:`esba.model.spatial.Model3D`: g(q, lambda) = dU/dq = 0 in the 3n unknowns
q = [theta; psi; tau] with the parameters affine in lambda (p = p0 + lambda dp). It answers the
same questions (g, H, dg/dlambda; the third derivatives of the extended systems by CasADi's AD;
the model's domain) and hands the corrector two dense kernels of its own
(:meth:`SpatialPathProblem.corrector_kernels`): the planar ones stand on the chain's O(n) Hessian
structure (:mod:`esba.model.structured`), which the 3-D Hessian does not have. Everything else —
pseudo-arclength steps, folds and branch points located by their extended systems, branch
switching, quasi-static ramps with their jumps — is the planar engine's, unchanged.

The parameters a 3-D path follows (:data:`PARAMETERS_3D`): the pressure, a payload's magnitude,
its direction in the plane (``omega``) and out of it (``beta``), its point (``at``), and the load
factor on every payload, moment and the weight (``load``); any other name of the model's
parameters (``mz1``, ``GJ``, ...) in the model's own unit from the API.

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> p = SpatialPathProblem.from_scene(Scene(pressure=0.1, payloads=(Payload(1.0, 90.0),)), "beta")
>>> p.name, p.unit, p.lam0, p.domain, p.n
('beta1', 'deg', 0.0, (-90.0, 90.0), 9)
>>> SpatialPathProblem.from_scene(Scene(pressure=0.1), "r2")
Traceback (most recent call last):
...
esba.paths.problem.PathError: parameter='r2': a 3-D path follows pressure, payload, omega, beta, at, load (the section's stiffnesses belong to the scene's geometry)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import casadi as ca
import numpy as np

from esba.model.generated import domain_lower_bound
from esba.model.spatial import Model3D
from esba.paths.problem import OPEN_END_INSET, PathError
from esba.solvers.dense import ldl_solve_sx, ldl_sx
from esba.solvers.native import HOT_RUNS, Kernel, packed
from esba.solvers.newton import bordered_layout

from .spatial import COMPILE_MAX_SEGMENTS, SpatialError, _ipopt, load_names

__all__ = ["SpatialPathProblem", "PARAMETERS_3D"]


@dataclass(frozen=True)
class _Kind3:
    model: str
    unit: str
    to_model: float
    scale: float
    low: float
    high: float
    open_low: bool = False
    period: float | None = None
    what: str = ""


#: The scene parameters a 3-D path follows (a payload's take its number: ``beta2``).
PARAMETERS_3D: dict[str, _Kind3] = {
    "pressure": _Kind3("P", "MPa", 1.0, 0.1, 0.0, math.inf, what="pressure"),
    "payload": _Kind3("F{k}", "N", 1.0, 1.0, 0.0, math.inf, what="payload magnitude"),
    "omega": _Kind3("Omega{k}", "deg", math.pi / 180.0, 45.0, -math.inf, math.inf, period=360.0, what="payload direction from the vertical, in the plane"),
    "beta": _Kind3("Beta{k}", "deg", math.pi / 180.0, 10.0, -90.0, 90.0, what="payload direction out of the bending plane"),
    "at": _Kind3("s{k}", "1 (fraction of L)", 1.0, 0.1, 0.0, 1.0, open_low=True, what="payload point"),
    "load": _Kind3("", "1 (load factor)", 1.0, 1.0, 0.0, math.inf, what="factor on every payload, moment and the weight"),
}


def _split(name: str) -> tuple[str, int]:
    allowed = ", ".join(PARAMETERS_3D)
    if not isinstance(name, str):
        raise PathError(f"parameter={name!r}: a 3-D path follows {allowed}")
    if name in PARAMETERS_3D:
        return name, 1
    base = name.rstrip("0123456789")
    digits = name[len(base):]
    if base in ("payload", "omega", "beta", "at") and digits and int(digits) >= 1:
        return base, int(digits)
    raise PathError(f"parameter={name!r}: a 3-D path follows {allowed} (the section's stiffnesses belong to the scene's geometry)")


# ---------------------------------------------------------------------------------------------
# the CasADi functions of a 3-D path (in the model's registry)


def _symbols(model: Model3D):
    npar = len(model.parameters)
    q = ca.SX.sym("q", model.size)
    p = ca.SX.sym("p", npar)
    dp = ca.SX.sym("dp", npar)
    args = ca.vertsplit(p) if npar else []
    return q, p, dp, model["gradient"](q, *args), model["hessian"](q, *args)




def _kernel(model: Model3D, which: str) -> Kernel:
    """A packed Function of a 3-D model's path as a :class:`Kernel`: ``ghl`` (g, H, dg/dlambda),
    and ``slope`` (v . H v and its derivative along a direction (t_q, t_lambda)), compiled up to
    :data:`COMPILE_MAX_SEGMENTS`; ``fold`` (the extended systems' third derivatives, a few calls a special point: an MX
    graph, interpreted, so that neither SymPy-sized expressions nor gcc are spent on it)."""
    key = ("path3d", which)
    found = model.registry.get(key)
    if found is None:
        mode = "auto" if model.n <= COMPILE_MAX_SEGMENTS else "never"
        if which == "fold":
            npar = len(model.parameters)
            q, p, dp, v = ca.MX.sym("q", model.size), ca.MX.sym("p", npar), ca.MX.sym("dp", npar), ca.MX.sym("v", model.size)
            args = ca.vertsplit(p) if npar else []
            g, h = model["gradient"](q, *args), model["hessian"](q, *args)
            hv = ca.mtimes(h, v)
            vg_l = ca.jtimes(ca.dot(v, g), p, dp)
            fun = ca.Function("esba3d_path_fold", [q, p, dp, v],
                              [g, h, ca.jtimes(g, p, dp), hv, ca.jacobian(hv, q), ca.jtimes(hv, p, dp), ca.jtimes(vg_l, p, dp)])
            mode = "never"
        else:
            q, p, dp, g, h = _symbols(model)
            opts = {"cse": model.n <= COMPILE_MAX_SEGMENTS}
            if which == "ghl":
                fun = ca.Function("esba3d_path_ghl", [q, p, dp], [g, h, ca.jtimes(g, p, dp)], opts)
            else:
                v, t = ca.SX.sym("v", model.size), ca.SX.sym("t", model.size + 1)
                mu = ca.dot(v, ca.mtimes(h, v))
                slope = ca.jtimes(mu, q, t[: model.size]) + ca.jtimes(mu, p, dp) * t[model.size]
                fun = ca.Function("esba3d_path_slope", [q, p, dp, v, t], [mu, slope], opts)
        found = Kernel(packed(fun, f"{fun.name()}_packed"), mode, model.n, HOT_RUNS if mode == "auto" else 0)
        model.registry[key] = found
    return found


def _bordered_sx(problem: SpatialPathProblem) -> ca.Function:
    """One Newton step on the bordered system of a 3-D model as one SX Function with the packed input
    and output of :func:`esba.solvers.newton.bordered_function` (iterations = 1): the block
    elimination by an unrolled dense LDL^T of H (O(N^3) operations, N = 3n: for small n), its
    pivots giving the Morse index, and u = (-H^-1 g_lambda, 1) at the step's end."""
    model = problem.model
    N, npar = model.size, len(model.parameters)
    zin = ca.SX.sym("z", 2 * (N + 1) + 2 + 2 * npar)
    x0, c, c0, crit = zin[: N + 1], zin[N + 1: 2 * N + 2], zin[2 * N + 2], zin[2 * N + 3]
    p0, dp = zin[2 * N + 4: 2 * N + 4 + npar], zin[2 * N + 4 + npar:]
    names = list(model.parameters)

    def terms(x):
        q, lam = x[:N], x[N]
        p = p0 + lam * dp
        args = ca.vertsplit(p)
        g = model["gradient"](q, *args)
        h = model["hessian"](q, *args)
        h = 0.5 * (h + h.T)
        return q, p, g, h

    def g_lambda(q, p):
        ps = ca.SX.sym("ps", npar)
        gs = model["gradient"](q, *ca.vertsplit(ps))
        return ca.substitute(ca.jtimes(gs, ps, dp), ps, p)

    def margin(q, p):
        L = p[names.index("L")]
        m = L
        if "r1" in names:
            r1, r2, d = (p[names.index(k)] for k in ("r1", "r2", "d"))
            m = ca.fmin(ca.fmin(m, r1), ca.fmin(r2, ca.fmin(r1 - r2 - d, d + r1)))
            if model.effects.radial:
                lb = domain_lower_bound(model.n, L, r1, r2, d, maximum=ca.fmax)
                m = ca.fmin(m, ca.mmin(q[: model.n] - lb))
        return m

    q, p, g, h = terms(x0)
    gl = g_lambda(q, p)
    Lf, d = ldl_sx(h, N)
    ct, cl = c[:N], c[N]
    r_c = ca.dot(c, x0) - c0
    y = ldl_solve_sx(Lf, d, g, N)
    zz = ldl_solve_sx(Lf, d, gl, N)
    dlam = (ca.dot(ct, y) - r_c) / (cl - ca.dot(ct, zz))
    dx = ca.vertcat(-y - zz * dlam, dlam)
    x1 = x0 + dx
    q1, p1, g1, h1 = terms(x1)
    gl1 = g_lambda(q1, p1)
    L1, d1 = ldl_sx(h1, N)
    piv = ca.vertcat(*d1)
    scale = ca.mmax(ca.fabs(piv)) + 1e-300
    morse = ca.sum1(piv < -crit * scale)
    u = -ldl_solve_sx(L1, d1, gl1, N)
    out = ca.vertcat(x1, ca.mmax(ca.fabs(g)), ca.mmax(ca.fabs(g1)), ca.fabs(r_c), ca.fabs(ca.dot(c, x1) - c0), ca.mmax(ca.fabs(dx)),
                     margin(q, p), margin(q1, p1), morse, ca.mmin(piv) / scale, ca.mmin(ca.fabs(piv)) / scale, scale, u, 1.0)
    return ca.Function("esba3d_bordered", [zin], [out], ["z"], ["out"], {"cse": True})


def _critical_sx(problem: SpatialPathProblem, iterations: int = 10) -> ca.Function:
    """:func:`esba.solvers.newton.critical_function` for a dense Hessian: inverse iteration from v0
    by the unrolled LDL^T, mu = v . H v and its rate along t, one SX Function [q, lambda, v0, t, p0, dp] -> [v, mu, slope]."""
    model = problem.model
    N, npar = model.size, len(model.parameters)
    q, lam, v0, t = ca.SX.sym("q", N), ca.SX.sym("lam"), ca.SX.sym("v0", N), ca.SX.sym("t", N + 1)
    p0, dp = ca.SX.sym("p0", npar), ca.SX.sym("dp", npar)
    p = p0 + lam * dp
    h = model["hessian"](q, *ca.vertsplit(p))
    h = 0.5 * (h + h.T)
    Lf, d = ldl_sx(h, N)
    v = v0 / ca.norm_2(v0)
    for _ in range(iterations):
        w = ldl_solve_sx(Lf, d, v, N)
        v = w / ca.norm_2(w)
    vf = ca.SX.sym("vf", N)
    mu_of = ca.dot(vf, ca.mtimes(h, vf))
    mu = ca.substitute(mu_of, vf, v)
    slope = ca.substitute(ca.jtimes(mu_of, ca.vertcat(q, lam), t), vf, v)
    z = ca.vertcat(q, lam, v0, t, p0, dp)
    return ca.Function("esba3d_critical", [z], [ca.vertcat(v, mu, slope)], ["z"], ["out"], {"cse": True})


class _Bordered:
    """The corrector's kernel for a dense Hessian: one Newton step on [[H, g_lambda], [c]] a call,
    with the packed input and output of :func:`esba.solvers.newton.bordered_function` (iterations = 1).

    The step is a dense solve of the (3n + 1)-square bordered system; the Morse index and the
    pivots' summary come from H's eigenvalues (the same signs, Sylvester's law), the tangent
    u = (-H^-1 g_lambda, 1) from a dense solve. The evaluation at the step's end is kept for the
    next call, which starts there.
    """

    def __init__(self, problem: SpatialPathProblem):
        self.prob = problem
        self.N = problem.n
        self.npar = len(problem.p0)
        self.lay = bordered_layout(self.N, 1)
        self.size = self.lay["u"].stop
        self._last: tuple[bytes, tuple] | None = None

    def _eval(self, x: np.ndarray, p0: np.ndarray, dp: np.ndarray):
        key = x.tobytes() + p0.tobytes() + dp.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        q, lam = x[:-1], float(x[-1])
        p = p0 + lam * dp
        margin = self.prob.margin(q, p)
        if margin > 0:
            g, h, gl = self.prob.ghl_p(q, p, dp)
        else:
            g = h = gl = None
        out = (margin, g, h, gl)
        self._last = (key, out)
        return out

    def run(self, z: np.ndarray) -> np.ndarray:
        N, lay = self.N, self.lay
        z = np.asarray(z, dtype=float)
        x0 = z[: N + 1].copy()
        c, c0, crit = z[N + 1: 2 * N + 2], float(z[2 * N + 2]), float(z[2 * N + 3])
        p0, dp = z[2 * N + 4: 2 * N + 4 + self.npar], z[2 * N + 4 + self.npar:]
        out = np.full(self.size, np.nan)
        res, rcs, margins = np.full(2, np.inf), np.full(2, np.inf), np.full(2, -1.0)
        out[lay["steps"]] = np.inf
        m0, g, h, gl = self._eval(x0, p0, dp)
        margins[0] = m0
        x1 = x0
        if m0 > 0 and np.all(np.isfinite(g)) and np.all(np.isfinite(h)) and np.all(np.isfinite(gl)):
            res[0], rcs[0] = float(np.max(np.abs(g))), abs(float(c @ x0) - c0)
            jac = np.empty((N + 1, N + 1))
            jac[:N, :N], jac[:N, N], jac[N, :] = h, gl, c
            try:
                dx = np.linalg.solve(jac, -np.concatenate([g, [float(c @ x0) - c0]]))
            except np.linalg.LinAlgError:
                dx = None
            if dx is not None and np.all(np.isfinite(dx)):
                out[lay["steps"]] = float(np.max(np.abs(dx)))
                x1 = x0 + dx
                m1, g1, h1, gl1 = self._eval(x1, p0, dp)
                margins[1] = m1
                if m1 > 0 and np.all(np.isfinite(g1)) and np.all(np.isfinite(h1)) and np.all(np.isfinite(gl1)):
                    res[1], rcs[1] = float(np.max(np.abs(g1))), abs(float(c @ x1) - c0)
                    w = np.linalg.eigvalsh(h1)
                    scale = float(np.max(np.abs(w))) + 1e-300
                    out[lay["morse"]] = float(np.sum(w < -crit * scale))
                    out[lay["min_pivot"]] = float(w[0]) / scale
                    out[lay["small_pivot"]] = float(np.min(np.abs(w))) / scale
                    out[lay["pivot_scale"]] = scale
                    try:
                        u = np.concatenate([-np.linalg.solve(h1, gl1), [1.0]])
                    except np.linalg.LinAlgError:
                        u = np.full(N + 1, np.nan)
                    out[lay["u"]] = u
        out[lay["x"]] = x1
        out[lay["res"]], out[lay["rc"]], out[lay["margin"]] = res, rcs, margins
        return out

    __call__ = run


class _Critical:
    """The eigenpair of H nearest zero and its rate along a direction (the planar engine's
    :func:`esba.solvers.newton.critical_function`, dense): [v, mu, d mu / ds] of
    [q, lambda, v0, t, p0, dp]. Of the eigenvalues nearest zero (within 1e-9 of the largest) the
    vector closest to ``v0`` is taken, as inverse iteration from ``v0`` would converge to it."""

    def __init__(self, problem: SpatialPathProblem):
        self.prob = problem
        self.N = problem.n

    def __call__(self, z: np.ndarray) -> np.ndarray:
        N = self.N
        q, lam, v0, t = z[:N], float(z[N]), z[N + 1: 2 * N + 1], z[2 * N + 1: 3 * N + 2]
        npar = len(self.prob.p0)
        p0, dp = z[3 * N + 2: 3 * N + 2 + npar], z[3 * N + 2 + npar: 3 * N + 2 + 2 * npar]  # the call's, not the problem's:
        p = p0 + lam * dp  # problems that differ only in p0 (esba.analysis.folds.Plane's lines) share this kernel
        _, h, _ = self.prob.ghl_p(q, p, dp)
        w, V = np.linalg.eigh(h)
        a = np.abs(w)
        near = np.flatnonzero(a <= a.min() + 1e-9 * (a.max() + 1e-300))
        k = int(near[np.argmax(np.abs(V[:, near].T @ v0))]) if len(near) > 1 else int(np.argmin(a))
        v = V[:, k]
        if float(v @ v0) < 0:
            v = -v
        _, slope = _kernel(self.prob.model, "slope").run(np.concatenate([q, p, dp, v, t]))
        return np.concatenate([v, [float(w[k]), float(slope)]])

    run = __call__


# ---------------------------------------------------------------------------------------------
# the problem


@dataclass(frozen=True, eq=False)
class SpatialPathProblem:
    """g(q, lambda) = 0 of one spatial model with p = p0 + lambda dp (see the module).

    The attributes are :class:`esba.paths.problem.PathProblem`'s; :attr:`n` is the number of
    unknowns, 3 x the segment count (:attr:`segments`).
    """

    model: Model3D
    p0: np.ndarray
    dp: np.ndarray
    name: str
    unit: str
    domain: tuple[float, float] = (-math.inf, math.inf)
    scale: float = 1.0
    period: float | None = None
    scene: object = None
    lam0: float = 0.0
    pressure: float | None = None
    what: str = ""
    registry: dict = field(default_factory=dict, repr=False)

    # -- constructors ------------------------------------------------------------------------

    @classmethod
    def from_values(cls, model: Model3D, values: Mapping[str, float], parameter: str, *, scene=None) -> SpatialPathProblem:
        """Follow ``parameter`` of ``model`` from ``values`` (model units, every parameter given):
        a name of :data:`PARAMETERS_3D` (degrees for the directions) or any of the model's own
        parameters (its own unit)."""
        if not isinstance(model, Model3D):
            raise PathError(f"model={model!r}: expected a Model3D (esba.model.spatial.load_model3d)")
        values = dict(values)
        names = list(model.parameters)
        missing = [k for k in names if k not in values]
        if missing:
            raise PathError(f"values: the model {model.path.name} needs {', '.join(missing)}")
        p_all = model.param_vector(values)
        if not np.all(np.isfinite(p_all)):
            bad = [k for k in names if not math.isfinite(float(values[k]))]
            raise PathError(f"values: {', '.join(bad)} not finite")
        pressure = float(values["P"]) if "P" in values else None
        if parameter in names and parameter not in PARAMETERS_3D:
            i = names.index(parameter)
            dp = np.zeros(len(names))
            dp[i] = 1.0
            p0 = p_all.copy()
            p0[i] = 0.0
            lam0 = float(values[parameter])
            return cls(model, p0, dp, parameter, "model unit", (-math.inf, math.inf), max(1.0, abs(lam0)), None, scene, lam0, pressure, parameter)
        base, k = _split(parameter)
        kind = PARAMETERS_3D[base]
        if base == "load":
            loads = load_names(model)
            if not any(float(values[n]) != 0.0 for n in loads):
                raise PathError("parameter='load': the model carries no payload, moment or weight to scale")
            zero = dict(values, **{n: 0.0 for n in loads})
            p0 = model.param_vector(zero)
            return cls(model, p0, p_all - p0, "load", kind.unit, (0.0, math.inf), kind.scale, None, scene, 1.0, pressure, kind.what)
        mname = kind.model.format(k=k)
        if mname not in names:
            if base == "pressure":
                raise PathError(f"parameter='pressure': the model {model.path.name} has no pressure")
            have = sum(1 for n in names if n.startswith("F") and n[1:].isdigit())
            raise PathError(f"parameter={parameter!r}: the model has {have} payload{'s' if have != 1 else ''}; add one (--payload N) to follow its {kind.what}")
        i = names.index(mname)
        lam0 = float(values[mname]) / kind.to_model
        low, high = kind.low, kind.high
        if kind.open_low:
            low += OPEN_END_INSET * kind.scale
        p0 = p_all.copy()
        p0[i] = 0.0
        dp = np.zeros(len(names))
        dp[i] = kind.to_model
        label = f"{base}{k}" if base in ("payload", "omega", "beta", "at") else base
        return cls(model, p0, dp, label, kind.unit, (low, high), kind.scale, kind.period, scene, lam0, pressure, kind.what)

    @classmethod
    def from_scene(cls, scene, parameter: str, section: Mapping[str, float] | None = None, *, gravity_direction=None) -> SpatialPathProblem:
        """Follow ``parameter`` of a scene in 3-D (its payloads may point out of the plane; its weight
        along ``gravity_direction``; the section stiffnesses given or the eccentric section's)."""
        from esba.model.spatial import load_model3d

        from .spatial import scene_values3d

        _split(parameter)  # a parameter the 3-D path does not follow is refused before any model is loaded
        base, k = _split(parameter)
        if base in ("payload", "omega", "beta", "at") and k > len(scene.payloads):
            have = len(scene.payloads)
            raise PathError(f"parameter={parameter!r}: the scene has {have} payload{'s' if have != 1 else ''}; add one (--payload N) to follow its {PARAMETERS_3D[base].what}")
        if base == "load" and not (scene.payloads or scene.gravity):
            raise PathError("parameter='load': the scene has no payload and no gravity to scale")
        try:
            effects, values = scene_values3d(scene, section, scene.down(gravity_direction))
        except SpatialError as exc:
            raise PathError(str(exc)) from None
        model = load_model3d(scene.segments, effects, scene.variant)
        return cls.from_values(model, values, parameter, scene=scene)

    # -- what the engine asks ------------------------------------------------------------------

    @property
    def n(self) -> int:
        """Unknowns: 3 x segments."""
        return self.model.size

    @property
    def segments(self) -> int:
        return self.model.n

    def params(self, lam: float) -> np.ndarray:
        return self.p0 + lam * self.dp

    def values(self, lam: float) -> dict[str, float]:
        """The model's parameter values at lambda, by name."""
        return dict(zip(self.model.parameters, map(float, self.params(lam))))

    def ghl_p(self, q: np.ndarray, p: np.ndarray, dp: np.ndarray):
        N = self.n
        out = _kernel(self.model, "ghl").run(np.concatenate([q, p, dp]))
        h = out[N: N + N * N].reshape(N, N)
        return out[:N].copy(), 0.5 * (h + h.T), out[N + N * N:].copy()

    def ghl(self, q: np.ndarray, lam: float):
        """g, H (symmetrised) and dg/dlambda at (q, lambda)."""
        return self.ghl_p(np.asarray(q, dtype=float), self.params(lam), self.dp)

    def extended_terms(self, q: np.ndarray, lam: float, v: np.ndarray):
        """As :meth:`esba.paths.problem.PathProblem.extended_terms`, in the 3n unknowns."""
        N = self.n
        out = _kernel(self.model, "fold").run(np.concatenate([q, self.params(lam), self.dp, v]))
        g, h, gl = out[:N].copy(), out[N: N + N * N].reshape(N, N), out[N + N * N: 2 * N + N * N].copy()
        at = 2 * N + N * N
        hv, hv_t = out[at: at + N].copy(), out[at + N: at + N + N * N].reshape(N, N, order="F").copy()
        hv_l = out[at + N + N * N: at + 2 * N + N * N].copy()
        return g, 0.5 * (h + h.T), gl, hv, hv_t, hv_l, float(out[-1])

    def fold_terms(self, q: np.ndarray, lam: float, v: np.ndarray):
        return self.extended_terms(q, lam, v)[3:]

    def hessians(self, q: np.ndarray, lam: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q, dtype=float))
        lam = np.asarray(lam, dtype=float).ravel()
        return np.array([self.ghl(t, float(x))[1] for t, x in zip(q, lam)]).reshape(len(q), self.n, self.n)

    def _length(self, lam: float) -> float:
        return float(self.params(lam)[list(self.model.parameters).index("L")])

    def tip(self, q: np.ndarray, lam: float) -> np.ndarray:
        """Tip position [x, y, z] (mm) at (q, lambda)."""
        return self.model.tip(q, self._length(lam))

    def tips(self, q: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Tip positions [x, y, z] of many points, shape (m, 3)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        lam = np.asarray(lam, dtype=float).ravel()
        return np.array([self.tip(t, float(x)) for t, x in zip(q, lam)]).reshape(len(q), 3)

    def _lower(self, p: np.ndarray) -> float:
        if not self.model.effects.radial:
            return -math.inf
        names = list(self.model.parameters)
        return float(domain_lower_bound(self.segments, *(float(p[names.index(k)]) for k in ("L", "r1", "r2", "d"))))

    def lower_bound(self, lam: float) -> np.ndarray:
        """The lowest value of each unknown (Eq. 10 for the in-plane angles, none for psi and tau)."""
        out = np.full(self.n, -math.inf)
        out[: self.segments] = self._lower(self.params(lam))
        return out

    def margin(self, q: np.ndarray, p: np.ndarray) -> float:
        """> 0 exactly where the model is defined: finite, a real geometry, theta inside Eq. 10's domain."""
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(p))):
            return -1.0
        where = self.registry.get("geometry")
        if where is None:
            names = list(self.model.parameters)
            where = self.registry["geometry"] = {k: names.index(k) for k in ("L", "r1", "r2", "d") if k in names}
        get = {k: float(p[i]) for k, i in where.items()}
        geo = [get["L"]]
        if "r1" in get:
            L, r1, r2, d = get["L"], get["r1"], get["r2"], get["d"]
            geo += [r1, r2, r1 - r2 - d, d + r1]
        m = min(geo)
        if m <= 0:
            return m
        low = self._lower(p)
        if math.isfinite(low):
            m = min(m, float(np.min(q[: self.segments] - low)))
        return m

    def defined(self, q: np.ndarray, lam: float) -> bool:
        return bool(math.isfinite(lam) and self.margin(np.asarray(q, dtype=float), self.params(lam)) > 0)

    def in_range(self, lam: float) -> bool:
        return bool(math.isfinite(lam) and self.domain[0] <= lam <= self.domain[1])

    def scene_at(self, lam: float):
        raise PathError(f"the 3-D path in {self.name} has no planar scene at {lam:g}")

    @property
    def unit_short(self) -> str:
        unit = self.unit.split(" ")[0]
        return "" if unit in ("1", "model") else f" {unit}"

    def describe(self, lam: float) -> str:
        return f"{self.name} = {lam:.6g}{self.unit_short}"

    # -- what the corrector and the ramps take from a problem that is not planar -----------------

    def corrector_kernels(self, compile: str = "auto"):
        """(bordered kernel, Newton steps per call, critical kernel) for :class:`esba.paths.corrector.Corrector`."""
        key = "kernels"
        if key not in self.registry:
            bordered, critical = _Bordered(self), _Critical(self)
            if self.segments <= COMPILE_MAX_SEGMENTS:
                # one SX Function each, interpreted by CasADi at first and compiled to C once it has run
                # HOT_RUNS times in this process (a long trace, the benchmark): a short trace pays no gcc
                after = HOT_RUNS if compile == "auto" else 0
                for name, build in (("bordered", _bordered_sx), ("critical", _critical_sx)):
                    mkey = ("path3d", name, compile)
                    if mkey not in self.model.registry:
                        self.model.registry[mkey] = Kernel(build(self), compile, self.segments, after)
                bordered, critical = self.model.registry[("path3d", "bordered", compile)], self.model.registry[("path3d", "critical", compile)]
            self.registry[key] = (bordered, 1, critical)
        return self.registry[key]

    def compile_kernels(self) -> bool:
        """Compile the path's kernels now (they are otherwise compiled after HOT_RUNS runs): True when
        they run compiled (a C compiler was found and n <= COMPILE_MAX_SEGMENTS)."""
        kernels = [_kernel(self.model, "ghl"), _kernel(self.model, "slope")]
        bordered, _, critical = self.corrector_kernels()
        kernels += [k for k in (bordered, critical) if isinstance(k, Kernel)]
        for k in kernels:
            k.count(HOT_RUNS)
        return all(k.compiled for k in kernels)

    def minimum(self, q0: np.ndarray, lam: float, tol: float) -> tuple[np.ndarray | None, int]:
        """IPOPT from q0 at lambda: the stable state it lands in (None if it fails), and 0 (IPOPT's
        iterations are not counted in 3-D)."""
        vals = self.values(lam)
        lb = self.lower_bound(lam)
        lb = np.where(np.isfinite(lb), lb * (1.0 - 1e-6), -np.inf)
        q, status = _ipopt(self.model, vals, np.maximum(np.asarray(q0, dtype=float), np.where(np.isfinite(lb), lb + 1e-9, -np.inf)), lb)
        if status != "Solve_Succeeded" or not self.defined(q, lam) or np.any(q[: self.segments] - lb[: self.segments] < 1e-6):
            return None, 0
        g, h, _ = self.ghl(q, lam)
        w = np.linalg.eigvalsh(h)
        if float(np.max(np.abs(g))) > 1e-7 or w[0] <= 1e-9 * max(1.0, float(np.max(np.abs(w)))):
            return None, 0
        return q, 0
