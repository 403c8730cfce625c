"""Equilibria of the spatial model: a load-ramped Newton method, certified by IPOPT.

The history is the planar solver's (:func:`esba.statics.equilibrium.solve`): the unloaded state at
the pressure, then every load (payloads, moments, weight) raised from 0 to its value in steps; the
last state is handed to IPOPT (exact Hessian) as the certificate. Up to
:data:`COMPILE_MAX_SEGMENTS` segments the history is first tried as the planar solver's fast path
does: one call of a compiled natural ramp (:func:`ramp_kernel`: the pressure from 0, then the loads,
each in :data:`esba.solvers.newton.STEPS` steps of a tangent predictor and Newton corrections on the
model's gradient and Hessian, factored by an unrolled dense LDL^T), accepted only by the engine's
one rule (:class:`esba.solvers.newton.Acceptance`: stationary at the end, every Hessian met positive
definite, every step's Newton iteration contracting, no corrector jumping) and inside the model's
domain at every step. Otherwise, and beyond that size, each step is a damped Newton solve on the
gradient from the previous state. The result says whether it is stable (the 3n x 3n Hessian
positive definite), and its smallest eigenvalue and its mode.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from typing import Mapping

import casadi as ca
import numpy as np

from esba.infra.threads import single_threaded
from esba.model.generated import domain_lower_bound
from esba.model.spatial import Model3D
from esba.solvers.dense import ldl_solve_sx, ldl_sx
from esba.solvers.minimise import WARM_MU_INIT
from esba.solvers.native import HOT_RUNS, Kernel, packed
from esba.solvers.newton import ACCEPTANCE, FINAL, NEWTON, STEPS, natural_expression

__all__ = ["Equilibrium3D", "newton3d", "solve3d", "descend3d", "load_names", "ramp_kernel", "newton_kernel", "newton_steps", "COMPILE_MAX_SEGMENTS"]

#: Up to this segment count the 3-D kernels (a solve's ramp, a path's g, H and corrector) are
#: dense SX Functions compiled to C once hot (a second of gcc at n = 3, cached); beyond it the
#: unrolled O((3n)^3) factorisation does not pay, and gcc's time grows fast with the 3n x 3n Hessian
#: (minutes at n = 8 on a busy machine) for a gain that a trace of tens of points never repays.
COMPILE_MAX_SEGMENTS = 4

#: Gradient norm (N*mm per rad, relative to the largest term) below which Newton stops.
NEWTON_TOL = 1e-12


def load_names(model: Model3D) -> list[str]:
    """The parameters that are ramped as loads: payload magnitudes, moments, couples, the mass."""
    out = []
    for name in model.parameters:
        if (name[:1] == "F" and name[1:].isdigit() or name[:2] in ("mx", "my", "mz", "cx", "cy", "cz") and name[2:].isdigit()
                or name == "M"):
            out.append(name)
    return out


@dataclass
class Equilibrium3D:
    q: np.ndarray
    n: int
    converged: bool
    stable: bool
    min_eigenvalue: float
    mode: np.ndarray
    gradient_norm: float
    ipopt_status: str
    tip: np.ndarray
    tip_rotation: np.ndarray
    notes: list[str] = field(default_factory=list)

    @property
    def theta(self) -> np.ndarray:
        return self.q[: self.n]

    @property
    def psi(self) -> np.ndarray:
        return self.q[self.n : 2 * self.n]

    @property
    def tau(self) -> np.ndarray:
        return self.q[2 * self.n :]

    @property
    def ok(self) -> bool:
        return self.converged and self.stable


def _bounds(model: Model3D, values: Mapping[str, float]) -> np.ndarray:
    lb = np.full(model.size, -np.inf)
    if model.effects.radial:
        lb[: model.n] = domain_lower_bound(model.n, *(float(values[k]) for k in ("L", "r1", "r2", "d")))
    return lb


@single_threaded
def newton3d(model: Model3D, values: Mapping[str, float], q0, *, max_iter: int = 60, lb=None) -> tuple[np.ndarray, bool, float]:
    """Damped Newton on the gradient from ``q0``: (q, converged, |gradient|).

    Each step solves H dq = -g (H shifted to positive definite when it is not, so the step goes
    down in energy), then halves it until the energy falls (or the gradient shrinks) and the state
    stays inside the model's domain ``lb``.
    """
    fun = model.state_function()
    p = model.param_vector(values)
    q = np.array(q0, dtype=float)
    lb = _bounds(model, values) if lb is None else lb

    def state(x):
        u, g, h = fun(x, p)
        return float(u), np.asarray(g).ravel(), np.asarray(h)

    u, g, h = state(q)
    scale = max(1.0, float(np.abs(h).max()))
    last = np.inf  # the size of the last step: one more step is taken after the gradient is small
    for _ in range(max_iter):
        gn = float(np.abs(g).max())
        if gn <= NEWTON_TOL * scale and (last < 1e-12 or gn == 0.0):
            return q, True, gn
        try:  # positive definite (the usual case): Cholesky
            c = np.linalg.cholesky(h)
            step = -np.linalg.solve(c.T, np.linalg.solve(c, g))
        except np.linalg.LinAlgError:  # not: step along the eigenvectors, curvature made positive
            w, V = np.linalg.eigh(h)
            shift = np.where(w > 1e-10 * scale, w, np.maximum(np.abs(w), 1e-6 * scale))
            step = -V @ ((V.T @ g) / shift)
        t = 1.0
        for _ in range(40):
            trial = q + t * step
            if np.all(trial > lb):
                ut, gt, ht = state(trial)
                if np.isfinite(ut) and (ut <= u + 1e-14 * max(1.0, abs(u)) or np.abs(gt).max() < gn):
                    break
            t *= 0.5
        else:
            return q, False, gn
        last = float(np.abs(trial - q).max())
        q, u, g, h = trial, ut, gt, ht
    return q, float(np.abs(g).max()) <= NEWTON_TOL * scale, float(np.abs(g).max())


def _ipopt(model: Model3D, values, q0, lb, warm: bool = False) -> tuple[np.ndarray, str]:
    """IPOPT on the energy from ``q0`` within the bounds ``lb``: (its point, its return status).

    ``warm``: ``q0`` is an equilibrium already (Newton's), so IPOPT starts with the barrier and the
    bound multipliers near zero (:data:`esba.solvers.minimise.WARM_MU_INIT`, as the planar solver's
    warm certificate): it accepts a minimiser after evaluating its optimality conditions there (one
    iteration) instead of leaving it along the central path and coming back (six)."""
    key = "ipopt_warm" if warm else "ipopt"
    solver = model.registry.get(key)
    if solver is None:
        q = ca.SX.sym("q", model.size)
        ps = ca.SX.sym("p", len(model.parameters))
        f = model.functions["energy"](q, *ca.vertsplit(ps))[0]
        opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-12, "ipopt.sb": "yes"}
        if warm:
            opts.update({"ipopt.mu_init": WARM_MU_INIT, "ipopt.bound_mult_init_method": "mu-based"})
        solver = ca.nlpsol("esba3d", "ipopt", {"x": q, "p": ps, "f": f}, opts)
        model.registry[key] = solver
    lbx = np.where(np.isfinite(lb), lb, -ca.inf)
    res = solver(x0=q0, p=model.param_vector(values), lbx=lbx)
    return np.asarray(res["x"]).ravel(), str(solver.stats()["return_status"])


def _parts3d(model: Model3D) -> tuple[ca.Function, ca.Function]:
    """The 3-D model's :func:`esba.solvers.newton.parts_function` and ``correction_function``
    (the same outputs; H factored by the unrolled dense LDL^T of :mod:`esba.solvers.dense`)."""
    N, npar = model.size, len(model.parameters)
    q, p, dp = ca.SX.sym("q", N), ca.SX.sym("p", npar), ca.SX.sym("dp", npar)
    args = ca.vertsplit(p) if npar else []
    g = model["gradient"](q, *args)
    h = model["hessian"](q, *args)
    h = 0.5 * (h + h.T)
    L, d = ldl_sx(h, N)
    piv = ca.vertcat(*d)
    rel = ca.mmin(piv) / (ca.mmax(ca.fabs(piv)) + 1e-300)
    step = ldl_solve_sx(L, d, g, N)
    gl = ca.jtimes(g, p, dp)
    parts = ca.Function("esba3d_parts", [q, p, dp], [g, step, ldl_solve_sx(L, d, gl, N), rel, piv, gl], {"cse": True})
    correction = ca.Function("esba3d_correction", [q, p], [g, step, rel], {"cse": True})
    return parts, correction


def ramp_kernel(model: Model3D) -> Kernel:
    """A solve's load history as one :class:`esba.solvers.native.Kernel`, input
    [q0, p0, dp_pressure, dp_loads], output [q, g, smallest relative pivot, worst contraction, largest
    jump, |g| after the pressure ramp, the least domain margin of the states met]: the natural ramp of
    the pressure from p0 (no pressure, no loads), then of the loads, each by
    :func:`esba.solvers.newton.natural_expression`; compiled to C once hot, up to
    :data:`COMPILE_MAX_SEGMENTS` segments."""
    key = ("ramp3d", STEPS, NEWTON, FINAL)
    found = model.registry.get(key)
    if found is None:
        N, npar = model.size, len(model.parameters)
        parts, correction = _parts3d(model)
        q0, p0, dpp, dpl = (ca.MX.sym(k, m) for k, m in (("q0", N), ("p0", npar), ("dpp", npar), ("dpl", npar)))
        qa, ga, lowa, worsta, statesa, jumpa = natural_expression(parts, q0, p0, dpp, 1.0, STEPS, NEWTON, FINAL, correction)
        qb, gb, lowb, worstb, statesb, jumpb = natural_expression(parts, qa, p0 + dpp, dpl, 1.0, STEPS, NEWTON, FINAL, correction)
        lb = ca.MX.sym("lb", N)
        states = ca.horzcat(statesa, statesb)
        margin = ca.mmin(states - ca.repmat(lb, 1, states.size2()))
        fun = ca.Function("esba3d_ramp", [q0, p0, dpp, dpl, lb],
                          [qb, gb, ca.fmin(lowa, lowb), ca.fmax(worsta, worstb), ca.fmax(jumpa, jumpb), ca.mmax(ca.fabs(ga)), margin])
        mode = "auto" if model.n <= COMPILE_MAX_SEGMENTS else "never"
        found = Kernel(packed(fun, "esba3d_ramp_packed"), mode, model.n, HOT_RUNS)
        model.registry[key] = found
    return found


def _fast_ramp(model: Model3D, values: Mapping[str, float], loads: list[str], lb: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The load history by :func:`ramp_kernel`: (q, |gradient|) when the engine's rule accepts it
    (see the module), else None."""
    names = list(model.parameters)
    full = model.param_vector(values)
    p0 = full.copy()
    dpp, dpl = np.zeros_like(full), np.zeros_like(full)
    if "P" in names:
        i = names.index("P")
        p0[i], dpp[i] = 0.0, full[i]
    for k in loads:
        i = names.index(k)
        p0[i], dpl[i] = 0.0, full[i]
    N = model.size
    low_bound = np.where(np.isfinite(lb), lb, -1e300)
    with np.errstate(invalid="ignore", over="ignore"):
        out = ramp_kernel(model)(np.concatenate([np.zeros(N), p0, dpp, dpl, low_bound]))
    q, g = out[:N], out[N : 2 * N]
    low, worst, jump, g_pressure, margin = out[2 * N : 2 * N + 5]
    gn = float(np.abs(g).max())
    finite = bool(np.all(np.isfinite(out)))
    if not finite or ACCEPTANCE.why_not(gn, float(low), float(worst), finite, float(jump)) or g_pressure > ACCEPTANCE.tol:
        return None
    if not (margin > 0 and np.all(q > lb)):
        return None
    return q, gn


@single_threaded
def solve3d(model: Model3D, values: Mapping[str, float], *, q0=None, steps: int = 4, certify: bool = True,
            descend: bool = False) -> Equilibrium3D:
    """The equilibrium of ``model`` at ``values`` along the load history (see the module's doc).

    ``q0``: a warm start, solved at the full load directly (no history).
    ``descend``: where the load history ends on an unstable state (it passed a sideways branch point,
    where the in-plane state stays an equilibrium by symmetry but stops being a minimum, or a fold),
    go on as the loaded actuator would: down the unstable mode to the stable state below it
    (:func:`descend3d`), and say so in ``notes``. Without it the unstable state is returned, marked.
    """
    values = dict(values)
    _check_loads(model, values)
    lb = _bounds(model, values)
    notes: list[str] = []
    fast = None
    if q0 is None and steps == STEPS and model.n <= COMPILE_MAX_SEGMENTS:
        fast = _fast_ramp(model, values, load_names(model), lb)
    if fast is not None:
        q, gn = fast
        converged = True
    elif q0 is None:
        q = np.zeros(model.size)
        loads = load_names(model)
        ok = True
        stage = {**values, **{k: 0.0 for k in loads}}
        pressure = float(values.get("P", 0.0))
        # the unloaded state: each segment's in-plane energy is separable, one damped Newton solve
        # from straight reaches it (the pressure is raised in steps only when that fails)
        q, ok, _ = newton3d(model, stage, q, lb=lb)
        if not ok:
            q, ok = np.zeros(model.size), True
            for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
                if "P" in stage:
                    stage["P"] = lam * pressure
                q, ok_step, _ = newton3d(model, stage, q, lb=lb)
                ok = ok and ok_step
        for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
            stage.update({k: lam * float(values[k]) for k in loads})
            q, ok_step, _ = newton3d(model, stage, q, lb=lb)
            ok = ok and ok_step
        if not ok:
            notes.append("a Newton step of the load history did not converge")
    else:
        q = np.array(q0, dtype=float)
    if fast is None:
        q, converged, gn = newton3d(model, values, q, lb=lb)
    status = _certify(model, values, q, lb, converged, notes) if certify else "not run"
    h = model.hessian(q, values)
    w, V = np.linalg.eigh(h)
    if descend and q0 is None and converged and not w[0] > 0:
        below = descend3d(model, values, q, lb)
        if below is not None:
            q, why = below
            notes.append(why)
            gn = float(np.abs(model.gradient(q, values)).max())
            if certify:
                status = _certify(model, values, q, lb, True, notes)
            w, V = np.linalg.eigh(model.hessian(q, values))
    tip, rot, _ = model.pose(q, values["L"])
    return Equilibrium3D(q, model.n, converged, bool(w[0] > 0), float(w[0]), V[:, 0], gn, status, tip, rot, notes)


def _certify(model: Model3D, values, q, lb, warm: bool, notes: list[str]) -> str:
    """IPOPT's certificate of the minimiser ``q`` (its return status); what it says against ``q`` goes to ``notes``."""
    qi, status = _ipopt(model, values, q, lb, warm=warm)
    if status == "Solve_Succeeded" and np.abs(qi - q).max() > 1e-8:
        notes.append(f"IPOPT moved the Newton solution by {np.abs(qi - q).max():.2e} rad")
    if status != "Solve_Succeeded":
        notes.append(f"IPOPT: {status}")
    return status


#: A load's magnitude in a parameter dict: a payload's force, a joint moment's or a couple's component.
_LOAD_KEY = re.compile(r"^(F|mx|my|mz|cx|cy|cz)\d+$")


def _check_loads(model: Model3D, values: Mapping[str, float]) -> None:
    """Refuse, in one line, a nonzero load in ``values`` that ``model`` does not carry (it would be
    dropped without a word: a moment given to a model generated without one, a second payload)."""
    for k, v in values.items():
        if k not in model.parameters and _LOAD_KEY.match(str(k)):
            try:
                zero = float(v) == 0.0
            except (TypeError, ValueError):
                zero = False
            if not zero:
                carried = [p for p in model.parameters if _LOAD_KEY.match(p)] or ["none"]
                raise SpatialError(f"{k}={v!r}: a load that model {model.path.name} does not carry (its loads: {', '.join(carried)}); "
                                   "generate a model with it (esba.model.spatial.load_model3d with its effects)")


#: How far (rad, the largest joint rotation) :func:`descend3d` first steps off an unstable state along
#: each of its unstable modes, both ways.
DESCENT_STEP = 0.05


def descend3d(model: Model3D, values: Mapping[str, float], q: np.ndarray, lb: np.ndarray | None = None) -> tuple[np.ndarray, str] | None:
    """The stable state below the unstable equilibrium ``q``: damped Newton (:func:`newton3d`, which
    goes down in energy) from ``q`` moved by :data:`DESCENT_STEP` along each unstable mode of the
    Hessian, both ways; the stable state of least energy, with a note saying what was done, or None
    when none is found. Of two mirror states (equal energy: loads in the bending plane, where the
    sideways bend and twist can go either way) it takes the one along the mode's sign with its largest
    component positive, so the same scene always gives the same state."""
    lb = _bounds(model, values) if lb is None else lb
    w, V = np.linalg.eigh(model.hessian(q, values))
    unstable = np.flatnonzero(w < 0)
    if unstable.size == 0:
        return None
    u0 = model.energy(q, values)
    found: list[tuple[float, int, np.ndarray]] = []
    for order, (k, sign) in enumerate((k, sign) for k in unstable[:2] for sign in (1.0, -1.0)):
        v = V[:, k] * (1.0 if V[np.argmax(np.abs(V[:, k])), k] > 0 else -1.0)
        start = q + sign * DESCENT_STEP * v / float(np.abs(v).max())
        if not np.all(start > lb):
            continue
        x, ok, _ = newton3d(model, values, start, lb=lb)
        if ok and np.linalg.eigvalsh(model.hessian(x, values))[0] > 0:
            found.append((model.energy(x, values), order, x))
    if not found:
        return None
    least = min(u for u, _, _ in found)
    ties = [f for f in found if f[0] - least <= 1e-9 * max(1.0, abs(least))]
    u, _, x = min(ties, key=lambda f: f[1])
    mirror = any(np.abs(f[2] - x).max() > 1e-6 for f in ties)
    return x, (f"the load history ends on an unstable state (least eigenvalue {w[0]:.4g}: past a sideways branch point or a fold, "
               f"energy {u0:.6g} N mm); the solve went on down its unstable mode to the stable state below it (energy {u:.6g} N mm)"
               + ("; it is one of two mirror states of equal energy (the other bends and twists the other way)" if mirror else ""))


def fold3d(model: Model3D, values: Mapping[str, float], parameter: str, q0, *, max_iter: int = 80, tol: float = 1e-11) -> tuple[float, np.ndarray, np.ndarray]:
    """A fold (or branch point) of the equilibria in ``parameter``: (value, q, null vector).

    Newton on the extended system  g(q, lam) = 0,  H(q, lam) v = 0,  v0 . v = 1  from the
    equilibrium ``q0`` at ``values`` (v0 its softest mode); the derivatives of H along v and in
    lam are central differences, so the iteration converges to the exact fold (its residuals are
    the model's own gradient and Hessian) at a linear rate near the end.
    """
    vals = dict(values)
    lam = float(vals[parameter])
    q = np.array(q0, dtype=float)
    w, V = np.linalg.eigh(model.hessian(q, vals))
    v0 = V[:, 0]
    v = v0.copy()
    N = model.size
    for _ in range(max_iter):
        vals[parameter] = lam
        g, H = model.gradient(q, vals), model.hessian(q, vals)
        r = np.concatenate([g, H @ v, [v0 @ v - 1.0]])
        scale = max(1.0, float(np.abs(H).max()))
        if np.abs(r[: 2 * N]).max() < tol * scale:
            return lam, q, v
        e = 1e-6 * max(1.0, abs(lam))
        gp, Hp = model.gradient(q, {**vals, parameter: lam + e}), model.hessian(q, {**vals, parameter: lam + e})
        gm, Hm = model.gradient(q, {**vals, parameter: lam - e}), model.hessian(q, {**vals, parameter: lam - e})
        eq = 1e-6
        Hv_q = np.column_stack([(model.hessian(q + eq * ei, vals) - model.hessian(q - eq * ei, vals)) @ v / (2 * eq) for ei in np.eye(N)])
        J = np.zeros((2 * N + 1, 2 * N + 1))
        J[:N, :N], J[:N, 2 * N] = H, (gp - gm) / (2 * e)
        J[N:2 * N, :N], J[N:2 * N, N:2 * N], J[N:2 * N, 2 * N] = Hv_q, H, (Hp - Hm) @ v / (2 * e)
        J[2 * N, N:2 * N] = v0
        dz = np.linalg.lstsq(J, -r, rcond=None)[0]
        q, v, lam = q + dz[:N], v + dz[N:2 * N], lam + dz[2 * N]
    raise RuntimeError(f"fold3d: no fold of {parameter} found from {values[parameter]:g} in {max_iter} iterations")


# ---------------------------------------------------------------------------------------------
# Scenes in 3-D and the tip's stiffness

#: The section parameters a 3-D actuator model takes beyond the planar ones (N*mm^2).
SECTION_PARAMETERS = ("EI_side", "GJ")


class SpatialError(ValueError):
    """A bad input to the 3-D solve (one line naming it)."""


def check_section(section: Mapping[str, float] | None, scene=None, complete: bool = True) -> dict[str, float]:
    """The section stiffnesses by name: every name known, every value finite and > 0.

    A stiffness not given is the eccentric section's (:func:`esba.model.section.section_stiffness`
    of the scene's r1, r2, d, E and fibre angle, with that module's documented defaults for what the
    paper does not give: the layer's width and thickness, the fibres slack), when ``scene`` is given;
    ``complete=False`` checks only the names and values given.
    """
    section = dict(section or {})
    for name, value in section.items():
        if name not in SECTION_PARAMETERS:
            raise SpatialError(f"section parameter {name!r}: unknown; allowed are {', '.join(SECTION_PARAMETERS)} (N*mm^2)")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise SpatialError(f"section parameter {name}={value!r}: expected a number > 0 (N*mm^2)") from None
        if not np.isfinite(v) or v <= 0:
            raise SpatialError(f"section parameter {name}={value!r}: expected a finite number > 0 (N*mm^2)")
        section[name] = v
    missing = [k for k in SECTION_PARAMETERS if k not in section]
    if missing and (complete or scene is not None):
        if scene is None:
            raise SpatialError(f"section parameter(s) {', '.join(missing)} missing: give them (N*mm^2), e.g. EI_side=4e5 GJ=2e4, or a scene to derive them from")
        from esba.model.section import section_stiffness

        a = scene.actuator
        k = section_stiffness(a.r1, a.r2, a.d, a.E, rho_deg=a.rho_deg)
        derived = {"EI_side": k.EI_side, "GJ": k.GJ}
        section.update({name: derived[name] for name in missing})
    return section


def check_direction(name: str, direction) -> np.ndarray:
    """A direction in space as a unit 3-vector: finite, not zero (one line naming ``name`` otherwise)."""
    try:
        v = np.asarray(direction, dtype=float).ravel()
    except (TypeError, ValueError):
        raise SpatialError(f"{name}={direction!r}: expected three numbers (x, y, z) of the base frame") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise SpatialError(f"{name}={direction!r}: expected three finite numbers (x, y, z) of the base frame")
    size = float(np.linalg.norm(v))
    if size == 0.0:
        raise SpatialError(f"{name}={direction!r}: a zero vector has no direction; give one such as (1, 0, 0) (down, the paper's)")
    return v / size


def scene_values3d(scene, section: Mapping[str, float] | None = None, gravity_direction=None) -> tuple[object, dict[str, float]]:
    """The spatial effects and parameter values of a scene (payloads may point out of plane; its
    moments and couples come in as the ``moment`` and ``couple`` terms).

    Gravity (when the scene has it) acts along ``gravity_direction`` in the base frame (x down, the
    paper's; any direction for an actuator mounted another way), with g of the scene; None: the
    scene's own (``gravity_direction`` in its file, :meth:`esba.model.scene.Scene.down`).
    """
    down = check_direction("gravity direction", scene.down(gravity_direction) if hasattr(scene, "down") else (gravity_direction or (1.0, 0.0, 0.0)))
    from esba.derive.effects3d import Effects3D
    from esba.model.closed_form import pressure_for_angle

    sec = check_section(section, scene)
    pressure = scene.pressure if scene.pressure is not None else pressure_for_angle(scene.unloaded())  # payloads do not enter it
    values = scene.parameters(pressure)
    values.update(sec)
    if scene.gravity:
        values.update(gx=values["g"] * down[0], gy=values["g"] * down[1], gz=values["g"] * down[2])
    effects = Effects3D.from_planar(scene.effects)
    joints = sum(m.kind == "joint" for m in scene.moments)
    if scene.moments:
        effects = dataclasses.replace(effects, moments=joints, couples=len(scene.moments) - joints)
    return effects, values


def solve_scene3d(scene, section: Mapping[str, float] | None = None, *, gravity_direction=None, steps: int = 4,
                  descend: bool = True) -> Equilibrium3D:
    """The 3-D equilibrium of ``scene`` (its payloads may point out of the bending plane; its weight
    along ``gravity_direction``, None: the scene's own) that its load history reaches: past a sideways branch point or a fold,
    the stable state below the unstable one (``descend``, :func:`solve3d`)."""
    from esba.model.spatial import load_model3d

    effects, values = scene_values3d(scene, section, gravity_direction)
    model = load_model3d(scene.segments, effects, scene.variant)
    return solve3d(model, values, steps=steps, descend=descend)


def tip_jacobian(model: Model3D, q, L: float, step: float = 1e-7) -> np.ndarray:
    """The 6 x 3n Jacobian of the tip's motion (translation; rotation, as the spatial angular
    velocity) per unit rate of q, by central differences of the generated kinematics."""
    q = np.asarray(q, dtype=float)
    J = np.zeros((6, model.size))
    for i in range(model.size):
        dq = np.zeros(model.size)
        dq[i] = step
        tp, Rp, _ = model.pose(q + dq, L)
        tm, Rm, _ = model.pose(q - dq, L)
        _, R0, _ = model.pose(q, L)
        W = (Rp - Rm) / (2 * step) @ R0.T
        J[:3, i] = (tp - tm) / (2 * step)
        J[3:, i] = (W[2, 1], W[0, 2], W[1, 0])
    return J


def tip_compliance(model: Model3D, values: Mapping[str, float], q) -> tuple[np.ndarray, np.ndarray]:
    """The tip's 6 x 6 compliance C = J H^-1 J^T and stiffness K = C^-1 at the equilibrium q.

    Rows and columns: tip force (x, y, z; N), tip moment (about x, y, z; N*mm), dead loads added at
    the tip, in the base frame. The state must be stable (H positive definite).
    """
    H = model.hessian(q, values)
    if np.linalg.eigvalsh(H)[0] <= 0:
        raise SpatialError("tip stiffness: the state is not stable (its Hessian is not positive definite)")
    J = tip_jacobian(model, q, values["L"])
    C = J @ np.linalg.solve(H, J.T)
    C = 0.5 * (C + C.T)
    return C, np.linalg.pinv(C, rcond=1e-12, hermitian=True)


def first_instability(model: Model3D, values: Mapping[str, float], load: str, q0, *, top: float, steps: int = 40) -> tuple[float, np.ndarray, np.ndarray] | None:
    """The first value of the parameter ``load`` in (values[load], top] at which the equilibrium
    followed from ``q0`` loses stability: (value, q, mode), None when it stays stable up to ``top``.

    The equilibrium is followed by Newton in ``steps`` equal steps; where the smallest eigenvalue of
    the 3n x 3n Hessian changes sign, Brent's method finds the zero (a fold or a branch point:
    the mode says which way it goes, in the plane or out of it).
    """
    vals = dict(values)
    start = float(vals[load])
    q = np.array(q0, dtype=float)

    def at(x: float, qs: np.ndarray) -> tuple[float, np.ndarray]:
        vals[load] = x
        qn, ok, _ = newton3d(model, vals, qs)
        if not ok:
            raise RuntimeError(f"first_instability: Newton lost the equilibrium at {load} = {x:g}")
        return float(np.linalg.eigvalsh(model.hessian(qn, vals))[0]), qn

    e0, q = at(start, q)
    if e0 <= 0:
        raise SpatialError(f"first_instability: the state at {load} = {start:g} is already unstable")
    grid = np.linspace(start, top, steps + 1)[1:]
    prev = start
    for x in grid:
        e, qn = at(x, q)
        if e <= 0:
            from scipy.optimize import brentq

            qa = q
            x_star = brentq(lambda y: at(y, qa)[0], prev, x, xtol=1e-12 * max(1.0, abs(x)), rtol=1e-12)
            _, qs = at(x_star, qa)
            w, V = np.linalg.eigh(model.hessian(qs, vals))
            return x_star, qs, V[:, 0]
        q, prev = qn, x
    return None


def load_for_twist(model: Model3D, values: Mapping[str, float], load: str, q0, *, angle: float, top: float, steps: int = 40) -> tuple[float, np.ndarray] | None:
    """The value of ``load`` (raised from values[load]) at which the total twist sum(tau) reaches
    ``angle`` (rad) on the equilibrium followed from ``q0``: (value, q), None when it stays below up to ``top``.
    The equilibrium is followed by Newton in ``steps`` steps; Brent's method finds the crossing."""
    from scipy.optimize import brentq

    vals = dict(values)
    n = model.n

    def twist(x: float, qs: np.ndarray) -> tuple[float, np.ndarray]:
        vals[load] = x
        qn, ok, _ = newton3d(model, vals, qs)
        if not ok:
            raise RuntimeError(f"load_for_twist: Newton lost the equilibrium at {load} = {x:g}")
        return float(abs(np.sum(qn[2 * n:]))) - angle, qn

    prev = float(vals[load])
    _, q = twist(prev, np.asarray(q0, dtype=float))
    for x in np.linspace(prev, top, steps + 1)[1:]:
        e, qn = twist(x, q)
        if e >= 0:
            qa = q
            x_star = brentq(lambda y: twist(y, qa)[0], prev, x, xtol=1e-12 * max(1.0, abs(x)))
            return x_star, twist(x_star, qa)[1]
        q, prev = qn, x
    return None


def newton_kernel(model: Model3D, iterations: int = 3) -> ca.Function:
    """One CasADi Function (q, p) -> (q after ``iterations`` full Newton steps, |gradient| there), for any n:
    a warm solve in one call from Python (MX, the steps by CasADi's sparse LDL^T of the symmetrised
    Hessian; no line search, so
    :func:`warm3d` and :func:`follow3d` check the result and fall back to :func:`newton3d`)."""
    key = ("newton_kernel", iterations)
    found = model.registry.get(key)
    if found is None:
        N, npar = model.size, len(model.parameters)
        qs, pss = ca.SX.sym("q", N), ca.SX.sym("p", npar)
        sargs = ca.vertsplit(pss) if npar else []
        hs = model.functions["hessian"](qs, *sargs)
        # the gradient and the symmetrised Hessian in one SX Function: their common subexpressions once
        gh = ca.Function("esba3d_gh", [qs, pss], [model.functions["gradient"](qs, *sargs), 0.5 * (hs + hs.T)], {"cse": True})
        q, ps = ca.MX.sym("q", N), ca.MX.sym("p", npar)
        x = q
        for _ in range(iterations):
            g, h = gh(x, ps)
            x = x - ca.solve(h, g, "ldl")
        g = model.functions["gradient"](x, *(ca.vertsplit(ps) if npar else []))
        found = ca.Function("esba3d_newton", [q, ps], [x, ca.mmax(ca.fabs(g))])
        model.registry[key] = found
    return found


def newton_steps(model: Model3D, iterations: int = 3):
    """(q, p) -> (q after ``iterations`` full Newton steps, |gradient| there), as NumPy: up to
    :data:`COMPILE_MAX_SEGMENTS` segments an SX Function of the dense unrolled LDL^T (a
    :class:`esba.solvers.native.Kernel`, compiled to C once hot), beyond it :func:`newton_kernel`."""
    if model.n > COMPILE_MAX_SEGMENTS:
        fun = newton_kernel(model, iterations)
        return lambda q, p: _mx_call(fun, q, p)
    key = ("newton_steps", iterations)
    kernel = model.registry.get(key)
    if kernel is None:
        N, npar = model.size, len(model.parameters)
        q, ps = ca.SX.sym("q", N), ca.SX.sym("p", npar)
        args = ca.vertsplit(ps) if npar else []
        x = q
        for _ in range(iterations):
            h = model["hessian"](x, *args)
            L, d = ldl_sx(0.5 * (h + h.T), N)
            x = x - ldl_solve_sx(L, d, model["gradient"](x, *args), N)
        g = model["gradient"](x, *args)
        fun = ca.Function("esba3d_newton_steps", [q, ps], [x, ca.mmax(ca.fabs(g))], {"cse": True})
        kernel = Kernel(packed(fun, "esba3d_newton_steps_packed"), "auto", model.n, HOT_RUNS)
        model.registry[key] = kernel
    N = model.size

    def call(q, p):
        out = kernel(np.concatenate([np.asarray(q, dtype=float).ravel(), np.asarray(p, dtype=float).ravel()]))
        return out[:N], float(out[N])

    return call


def _mx_call(fun: ca.Function, q, p):
    x, gn = fun(q, p)
    return np.asarray(x).ravel(), float(gn)


def _kernel_step(model: Model3D, step, p: np.ndarray, q: np.ndarray, lb: np.ndarray) -> np.ndarray | None:
    """``step(q, p)`` (:func:`newton_steps`) accepted when its end is finite, inside the domain and stationary; else None."""
    with np.errstate(invalid="ignore", over="ignore"):
        x, gn = step(q, p)
    if np.all(np.isfinite(x)) and np.all(x > lb) and gn <= 1e-9 * max(1.0, float(np.abs(x).max())):
        return x
    return None


@single_threaded
def warm3d(model: Model3D, values: Mapping[str, float], q0) -> np.ndarray:
    """The equilibrium near ``q0`` at ``values``: one call of :func:`newton_steps`, checked, else
    the damped :func:`newton3d` (a warm solve: no load history, no certificate)."""
    lb = _bounds(model, values)
    x = _kernel_step(model, newton_steps(model), model.param_vector(values), np.asarray(q0, dtype=float), lb)
    if x is None:
        x, ok, _ = newton3d(model, values, q0, lb=lb)
        if not ok:
            raise RuntimeError("warm3d: no equilibrium found near the start")
    return x


@single_threaded
def follow3d(model: Model3D, values: Mapping[str, float], parameter: str, path, q0) -> np.ndarray:
    """The equilibria along ``path`` (values of ``parameter``) from ``q0``: natural continuation, one
    call of :func:`newton_steps` a point (checked: the gradient at the end and the domain), the
    damped :func:`newton3d` where that check fails. Returns the states, shape (len(path), 3n)."""
    vals = dict(values)
    kernel = newton_steps(model)
    index = list(model.parameters).index(parameter)
    p = model.param_vector(vals)
    lb = _bounds(model, vals)
    q = np.array(q0, dtype=float)
    out = np.empty((len(path), model.size))
    for k, lam in enumerate(path):
        p[index] = lam
        x = _kernel_step(model, kernel, p, q, lb)
        if x is None:
            vals[parameter] = float(lam)
            x, ok, _ = newton3d(model, vals, q, lb=lb)
            if not ok:
                raise RuntimeError(f"follow3d: no equilibrium found at {parameter} = {lam:g}")
        q = x
        out[k] = q
    return out


@dataclass
class State3D:
    q: np.ndarray
    energy: float
    morse_index: int
    min_eigenvalue: float
    in_plane: bool
    tip: np.ndarray


def equilibria3d(scene, section: Mapping[str, float] | None = None, options=None) -> list[State3D]:
    """Every equilibrium of an in-plane ``scene`` in 3-D, sorted by energy.

    In-plane loads keep the plane a symmetry: the in-plane equilibria are exactly the planar
    model's (:func:`esba.statics.equilibria.equilibria`, its complete search), each judged again by
    the 3n x 3n Hessian; from every one that is unstable out of the plane, the damped Newton
    method runs down its out-of-plane modes (both signs) to the equilibria that branch off it.
    A scene with a payload out of the plane has no such symmetry: it is refused (one line).
    """
    from esba.model.spatial import load_model3d
    from esba.statics.equilibria import equilibria

    if scene.needs_3d:
        raise SpatialError("equilibria in 3-D: only for loads in the bending plane so far (the planar search is its in-plane part); "
                           "solve a scene with a payload out of the plane with solve_scene3d")
    effects, values = scene_values3d(scene, section)
    model = load_model3d(scene.segments, effects, scene.variant)
    planar = equilibria(scene, options)
    n = model.n
    found: list[np.ndarray] = []

    def add(q: np.ndarray) -> None:
        if not any(np.abs(q - f).max() < 1e-7 for f in found):
            found.append(q)

    for state in planar.states:
        q = np.concatenate([state.theta, np.zeros(2 * n)])
        add(q)
        w, V = np.linalg.eigh(model.hessian(q, values))
        for k in np.flatnonzero(w < 0):
            mode = V[:, k]
            if np.abs(mode[:n]).max() > 1e-8:  # an in-plane mode: the planar search has its neighbours
                continue
            for sign in (1.0, -1.0):
                qs, ok, _ = newton3d(model, values, q + sign * 1e-3 * mode / np.abs(mode).max())
                if ok and np.abs(qs[n:]).max() > 1e-6:
                    add(qs)
    out = []
    for q in found:
        w = np.linalg.eigvalsh(model.hessian(q, values))
        out.append(State3D(q, model.energy(q, values), int(np.sum(w < -1e-9 * max(1.0, abs(w).max()))), float(w[0]),
                           bool(np.abs(q[n:]).max() == 0.0), model.tip(q, values["L"])))
    return sorted(out, key=lambda s: (round(s.energy, 9), round(float(s.tip[2]), 9)))  # mirror pairs: -z first
