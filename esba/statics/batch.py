"""Equilibria for many scenes at once: the continuation engine mapped over a batch, compiled to C.

:func:`esba.statics.equilibrium.solve` pays IPOPT's set-up and CasADi's per-call overhead (25-40 us a
call) on every solve: a few ms each. A sweep of thousands of pressures, payloads or designs of
one model is instead solved here on the same engine, mapped over the batch:

1. **Natural continuation, compiled.** Each element follows the same physical load history as
   :func:`solve`: from the unloaded state (exact for a target angle: theta_i = Theta / n with the
   closed-form pressure of :func:`esba.model.closed_form.unloaded_pressure`; else natural
   continuation of the pressure from theta = 0), then natural continuation of the payloads and
   weight from 0 (:func:`esba.solvers.newton.natural_expression`: a tangent predictor and Newton
   corrections per step, each solve O(n) from the Hessian's structure). The whole history is one
   graph of fixed size, mapped over a chunk of the batch and, when a C compiler is found,
   generated to C by CasADi and compiled once (:mod:`esba.statics.compiled`: the shared library is
   cached, keyed by the hash of the model file, the options and the graph's builders, with a
   checksum verified before it is loaded). The settings are one frozen
   :class:`esba.statics.batch_options.BatchOptions`.
2. **Verification.** Every element is checked the way :func:`solve` checks its answers: the one
   acceptance rule of the engine (:class:`esba.solvers.newton.Acceptance`: every Hessian met on
   the ramps positive definite, every step contracting, no corrector going farther than its
   predictor), and from the gradient and Hessian at the end: finite, ``max |dU/dtheta| <=
   stationarity_tol``, not on the domain boundary, and a stability verdict from the Hessian's
   eigenvalues.
3. **A finer ramp, then pseudo-arclength.** An element whose ramp is refused is solved again with
   8 times the steps, compiled as the first (``retry``: where the path is only steep). One that is
   still refused goes to the engine's pseudo-arclength continuation of the same load history
   (:func:`esba.statics.equilibrium.load_history`, ``fallback``), which goes round a fold, locates
   it, takes the jump and finds the stable state after it: the element is flagged as having
   snapped, with the same notes as :func:`solve`. Every element ends with ``success``,
   ``stability``, ``ok`` and a ``message`` saying why it is not ok; no element is dropped and none
   is a silent NaN.

Examples
--------
>>> from esba.model.scene import Scene, Payload
>>> scenes = [Scene(pressure=p, payloads=(Payload(2.0),)) for p in (0.05, 0.1, 0.15)]
>>> r = solve_scenes(scenes, BatchOptions(compile="never"))
>>> bool(r.ok.all()), r.total_angle_deg.round(2).tolist()
(True, [-13.78, 9.92, 48.92])
>>> from esba.statics.equilibrium import solve
>>> bool(np.allclose(solve(scenes[1]).theta, r.theta[1], atol=1e-8))
True
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from esba.infra import checks
from esba.infra.interrupts import interrupts_raised
from esba.infra.threads import single_threaded
from esba.model.generated import Model, domain_lower_bound, near_domain_bound
from esba.model.scene import Scene
from esba.solvers.newton import Acceptance

from .batch_options import (
    DEFAULT_BATCH_OPTIONS,
    TAIL_CHUNK,
    BatchOptions,
    BatchOptionsError,
    batch_bytes,
    check_size,
)
from .compiled import (
    compile_library,
    compiler,
    decide_backend,
    mapped_functions,
    parameter_indices,
    prepare,
)
from .equilibrium import SolverOptions, load_history, stability_verdicts

__all__ = [
    "BatchOptions",
    "BatchOptionsError",
    "BatchResult",
    "solve_arrays",
    "solve_scenes",
    "compiler",
    "compile_library",
    "batch_bytes",
    "check_size",
    "decide_backend",
    "prepare",
    "METHODS",
]

#: How an element's answer was found: natural continuation, its finer retry, pseudo-arclength
#: continuation of the load history (through folds), or not at all.
METHODS = ("newton", "newton-retry", "continuation", "none")


# ---------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Equilibria of a batch: one row per element, in the order given.

    Attributes
    ----------
    pressure : ndarray, shape (N,)
        MPa (given, or from the target angle in closed form).
    theta : ndarray, shape (N, n)
        Segment angles, rad (the last iterate when the element is not ok).
    tip : ndarray, shape (N, 3)
        Tip x, y (mm) and orientation (rad).
    gradient_norm : ndarray, shape (N,)
        max |dU/dtheta_i| at theta, N mm/rad.
    eig_min, eig_max : ndarray, shape (N,)
        Smallest and largest Hessian eigenvalue, N mm/rad^2.
    stability : ndarray of str, shape (N,)
        ``stable``, ``critical``, ``unstable`` (or ``unknown`` when the Hessian is not finite).
    success : ndarray of bool, shape (N,)
        Finite, stationary and inside the domain.
    method : ndarray of str, shape (N,)
        One of :data:`METHODS`.
    messages : tuple of str
        Why each element is not ok (empty when it is).
    notes : tuple of tuple of str
        What happened on the way (a jump or a buckling on the load path, noted by the
        pseudo-arclength continuation that answered the element, as :func:`solve` notes it).
    snapped : ndarray of bool, shape (N,)
        The element's load history jumped at a fold (a snap-through) on the way.
    backend : str
        How the fast path ran: compiled (with the compiler and the cached library) or
        interpreted, and why.
    timings : dict
        Wall times in s: ``build``, ``compile``, ``fast``, ``retry``, ``fallback``, ``total``.
    """

    pressure: np.ndarray
    theta: np.ndarray
    tip: np.ndarray
    gradient_norm: np.ndarray
    eig_min: np.ndarray
    eig_max: np.ndarray
    stability: np.ndarray
    success: np.ndarray
    method: np.ndarray
    messages: tuple[str, ...]
    backend: str
    timings: dict = field(default_factory=dict)
    notes: tuple[tuple[str, ...], ...] = ()
    snapped: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.snapped is None:
            object.__setattr__(self, "snapped", np.zeros(len(self.pressure), dtype=bool))

    def __len__(self) -> int:
        return len(self.pressure)

    @property
    def ok(self) -> np.ndarray:
        """Converged and stable, per element."""
        return self.success & (self.stability == "stable")

    @property
    def total_angle(self) -> np.ndarray:
        """Total bending angle theta_TOL (Eq. 17), rad."""
        return np.sum(self.theta, axis=1)

    @property
    def total_angle_deg(self) -> np.ndarray:
        """Total bending angle, degrees."""
        return np.degrees(self.total_angle)

    @property
    def theta_deg(self) -> np.ndarray:
        """Segment angles, degrees."""
        return np.degrees(self.theta)

    def counts(self) -> dict[str, int]:
        """How many elements each method answered, and how many are ok / not ok."""
        out = {m: int(np.sum(self.method == m)) for m in METHODS}
        out["ok"] = int(np.sum(self.ok))
        out["not_ok"] = len(self) - out["ok"]
        return out

    def per_equilibrium_us(self) -> float:
        """Total wall time divided by the batch size, microseconds (compilation included)."""
        return 1e6 * self.timings.get("total", float("nan")) / max(1, len(self))


def _concat(parts: Sequence[tuple[np.ndarray, BatchResult]], size: int) -> BatchResult:
    """Merge group results back into the original order."""
    if len(parts) == 1 and np.array_equal(parts[0][0], np.arange(size)):
        return parts[0][1]
    n = parts[0][1].theta.shape[1]
    out = {
        "pressure": np.empty(size),
        "theta": np.empty((size, n)),
        "tip": np.empty((size, 3)),
        "gradient_norm": np.empty(size),
        "eig_min": np.empty(size),
        "eig_max": np.empty(size),
        "stability": np.empty(size, dtype=object),
        "success": np.zeros(size, dtype=bool),
        "method": np.empty(size, dtype=object),
        "snapped": np.zeros(size, dtype=bool),
    }
    messages = [""] * size
    notes: list[tuple[str, ...]] = [()] * size
    timings: dict[str, float] = {}
    backends = []
    for idx, r in parts:
        for k in out:
            out[k][idx] = getattr(r, k)
        for j, i in enumerate(idx):
            messages[i] = r.messages[j]
            notes[i] = r.notes[j]
        for k, v in r.timings.items():
            timings[k] = timings.get(k, 0.0) + v
        if r.backend not in backends:
            backends.append(r.backend)
    out["stability"] = out["stability"].astype(str)
    out["method"] = out["method"].astype(str)
    return BatchResult(messages=tuple(messages), notes=tuple(notes), backend="; ".join(backends), timings=timings, **out)


# ---------------------------------------------------------------------------------------------
# solving arrays of parameters


def _lower_bounds(model: Model, pv: np.ndarray) -> np.ndarray:
    """:meth:`Model.lower_bounds` for every column of ``pv``."""
    L, r1, r2, d = (pv[i] for i in parameter_indices(model)["geometry"])
    return domain_lower_bound(model.n, L, r1, r2, d)


_OUTPUTS = ("theta", "P", "grad", "hess", "tip", "min_pivot", "contraction", "jump", "theta_unloaded")


def _run(model: Model, pv: np.ndarray, targets: np.ndarray, angle_mode: bool, options: BatchOptions, bar, size_hint: int = 0) -> dict:
    (fun_big, fun_small), backend, build_s, compile_s = mapped_functions(model, options, angle_mode, max(pv.shape[1], size_hint))
    n, size = model.n, pv.shape[1]
    outs = {k: [] for k in _OUTPUTS}
    t0 = time.perf_counter()
    full = size - size % options.chunk
    small = min(options.chunk, TAIL_CHUNK)
    blocks = [(start, options.chunk, fun_big) for start in range(0, full, options.chunk)]
    blocks += [(start, small, fun_small) for start in range(full, size, small)]
    for start, chunk, fun in blocks:
        stop = min(size, start + chunk)
        block = pv[:, start:stop]
        tgt = targets[start:stop]
        if stop - start < chunk:  # pad the last block with copies of its last element
            pad = chunk - (stop - start)
            block = np.hstack([block, np.repeat(block[:, -1:], pad, axis=1)])
            tgt = np.concatenate([tgt, np.repeat(tgt[-1:], pad)])
        with interrupts_raised():  # a Ctrl-C inside CasADi's conversion to NumPy surfaces as a SystemError
            res = fun(block, tgt.reshape(1, -1))
            for k, v in zip(outs, res):
                outs[k].append(np.asarray(v)[:, : stop - start])
        if bar is not None:
            bar.update(stop - start)
    data = {k: np.hstack(v) for k, v in outs.items()}
    return {
        "theta": data["theta"].T.reshape(size, n),
        "P": data["P"].ravel(),
        "grad": data["grad"].T.reshape(size, n),
        "hess": data["hess"].T.reshape(size, n, n),
        "tip": data["tip"].T.reshape(size, 3),
        "min_pivot": data["min_pivot"].ravel(),
        "contraction": data["contraction"].ravel(),
        "jump": data["jump"].ravel(),
        "theta_unloaded": data["theta_unloaded"].T.reshape(size, n),
        "backend": backend,
        "build": build_s,
        "compile": compile_s,
        "fast": time.perf_counter() - t0,
    }


def _verify(model: Model, pv: np.ndarray, run: dict, options: BatchOptions):
    """success, stability, gradient norm, eigenvalues and messages of a natural-continuation run."""
    rule = Acceptance(tol=options.stationarity_tol, critical_tol=options.critical_tol)
    with np.errstate(invalid="ignore", over="ignore"):
        theta, grad, hess, P = run["theta"], run["grad"], run["hess"], run["P"]
        finite = np.all(np.isfinite(theta), axis=1) & np.all(np.isfinite(grad), axis=1) & np.all(np.isfinite(hess), axis=(1, 2))
        gnorm = np.where(finite, np.max(np.abs(np.where(np.isfinite(grad), grad, np.inf)), axis=1), np.inf)
        eig = np.full((len(P), model.n), np.nan)
        if finite.any():
            sym = 0.5 * (hess[finite] + np.swapaxes(hess[finite], 1, 2))
            eig[finite] = np.linalg.eigvalsh(sym)
        stability = stability_verdicts(eig, options.critical_tol)
        lb = _lower_bounds(model, pv)
        near = near_domain_bound(theta, lb[:, None], axis=1)
        pressure_ok = np.isfinite(P) & (P >= 0)
        accepted = rule.accepted_arrays(gnorm, run["min_pivot"], run["contraction"], run["jump"], finite)
        success = accepted & ~near & pressure_ok
    messages = [""] * len(P)
    for i in np.flatnonzero(~(success & (stability == "stable"))):
        if not pressure_ok[i]:
            messages[i] = (
                f"target angle: would need a negative pressure ({P[i]:.4g} MPa)" if np.isfinite(P[i]) else "target angle: outside the model's domain for this actuator"
            )
        elif near[i]:
            messages[i] = "the solve stopped on the model's domain boundary (Eq. 10): not an equilibrium"
        elif not accepted[i]:
            why = rule.why_not(float(gnorm[i]), float(run["min_pivot"][i]), float(run["contraction"][i]), bool(finite[i]), float(run["jump"][i]))
            messages[i] = f"natural continuation of the load history was refused: it {why}; for pseudo-arclength continuation to follow"
        else:
            messages[i] = f"the equilibrium is {stability[i]}: smallest Hessian eigenvalue {eig[i, 0]:.3g} N mm/rad^2 (largest {eig[i, -1]:.3g})"
    return success, stability, gnorm, eig, messages, pressure_ok


def _continue(model: Model, pv_full: np.ndarray, pressure: float, unloaded: np.ndarray | None, options: BatchOptions):
    """One refused element by pseudo-arclength continuation of its load history: (theta, success,
    stability, gradient norm, eigenvalues, message, notes, snapped)."""
    history = load_history(model, pressure, pv_full, unloaded, _PALC_ONLY)
    theta = history.theta
    state = model.state(theta, pv_full)
    g, h = state["gradient"], state["hessian"]
    finite = bool(np.all(np.isfinite(g)) and np.all(np.isfinite(h)))
    gnorm = float(np.max(np.abs(g))) if finite else np.inf
    eig = np.sort(np.linalg.eigvalsh(0.5 * (h + h.T))) if finite else np.full(model.n, np.nan)
    stability = str(stability_verdicts(eig[None, :], options.critical_tol)[0])
    success = finite and not history.message and gnorm <= options.stationarity_tol
    message = history.message
    if not message and not finite:
        message = "the model's energy, gradient or Hessian is not finite at the result (overflow): not an equilibrium"
    elif not message and gnorm > options.stationarity_tol:
        message = f"max |dU/dtheta| = {gnorm:.3g} N mm/rad > stationarity_tol = {options.stationarity_tol:g}"
    elif not message and stability != "stable":
        message = f"the equilibrium is {stability}: smallest Hessian eigenvalue {eig[0]:.3g} N mm/rad^2 (largest {eig[-1]:.3g})"
    notes = tuple(history.notes(model, pv_full, pressure))
    return theta, state["tip"], success, stability, gnorm, eig, message, notes, bool(history.jumps)


#: The load history of a refused element: pseudo-arclength continuation at once (natural was refused).
_PALC_ONLY = SolverOptions(fast=False)


@single_threaded
def solve_arrays(
    model: Model,
    values: Mapping[str, float | Sequence[float] | np.ndarray],
    *,
    target_angle: float | Sequence[float] | np.ndarray | None = None,
    options: BatchOptions | None = None,
) -> BatchResult:
    """Equilibria of one model for a batch of parameter values.

    Parameters
    ----------
    model : Model
        The generated model (all elements share it).
    values : mapping
        Every name in ``model.parameters`` (radians for ``rho`` and ``Omega_k``), each a scalar
        or an array; arrays broadcast to the batch size. ``P`` is ignored with ``target_angle``.
    target_angle : float or array, optional
        The unloaded total angle (rad) whose closed-form pressure each element uses, as a scene's
        ``target_angle_deg``; without it the pressure ``P`` is given.
    options : BatchOptions, optional

    Returns
    -------
    BatchResult

    Examples
    --------
    >>> import math
    >>> from esba.model.generated import load_model
    >>> m = load_model(3)
    >>> v = dict(L=135.0, r1=8.0, r2=3.0, d=4.0, rho=math.radians(10), E=0.54, P=0.0,
    ...          F1=[0.0, 2.0], Omega1=math.pi / 2, s1=1.0)
    >>> r = solve_arrays(m, v, target_angle=math.pi / 2, options=BatchOptions(compile="never"))
    >>> r.theta_deg[1].round(2).tolist(), r.method.tolist()
    ([-3.29, 7.17, 21.44], ['newton', 'newton'])
    """
    options = DEFAULT_BATCH_OPTIONS if options is None else options
    if not isinstance(options, BatchOptions):
        raise BatchOptionsError(f"options={options!r}: expected a BatchOptions")
    t_start = time.perf_counter()
    if not isinstance(model, Model):
        raise BatchOptionsError(f"model={checks.quote(model)}: expected a Model (esba.model.generated.load_model)")
    if not isinstance(values, Mapping):
        raise BatchOptionsError(f"values={checks.quote(values)}: expected a mapping of parameter name to value or array")
    missing = [k for k in model.parameters if k not in values]
    if missing:
        raise BatchOptionsError(f"values: missing parameter(s) {checks.some(missing)}; the model {model.path.name} needs {', '.join(model.parameters)}")
    angle_mode = target_angle is not None
    given = {k: values[k] for k in model.parameters}
    if angle_mode:
        given["target_angle"] = target_angle
    arrays = []
    for k, v in given.items():
        try:
            a = np.atleast_1d(np.asarray(v, dtype=float))
        except (TypeError, ValueError, OverflowError):
            raise BatchOptionsError(f"{k}={checks.quote(v)}: expected a number or an array of numbers") from None
        if not np.all(np.isfinite(a)):
            where = int(np.flatnonzero(~np.isfinite(a.ravel()))[0])
            raise BatchOptionsError(f"{k}[{where}] is not a finite number: expected finite values")
        arrays.append(a)
    try:
        arrays = list(np.broadcast_arrays(*arrays))
    except ValueError:
        shapes = {k: np.shape(values[k]) for k in model.parameters}
        raise BatchOptionsError(f"parameter arrays of different lengths: {shapes}") from None
    if any(a.ndim != 1 for a in arrays):
        raise BatchOptionsError("every parameter must be a scalar or a 1-D array")
    size = check_size(len(arrays[0]), model.n, "a batch", BatchOptionsError)
    targets = arrays.pop() if angle_mode else np.zeros(size)
    pv = np.vstack(arrays) if arrays else np.zeros((0, size))

    bar = None
    if options.progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=size, unit="eq", desc=f"esba batch n={model.n}", leave=False, disable=None)  # None: only on a terminal
    try:
        run = _run(model, pv, targets, angle_mode, options, bar)
        success, stability, gnorm, eig, messages, pressure_ok = _verify(model, pv, run, options)
        method = np.where(success & (stability == "stable"), "newton", "none").astype(object)
        theta, tip, P, unloaded = run["theta"], run["tip"], run["P"], run["theta_unloaded"]
        notes: list[tuple[str, ...]] = [()] * len(P)
        snapped = np.zeros(len(P), dtype=bool)
        timings = {"build": run["build"], "compile": run["compile"], "fast": run["fast"], "retry": 0.0, "fallback": 0.0}

        # a finer ramp for the refused elements (that have a pressure), compiled as the first
        redo = np.where(~(success & (stability == "stable")) & pressure_ok)[0]
        if options.retry and len(redo):
            finer = options.denser()
            if bar is not None:
                bar.reset(total=len(redo))
                bar.set_description("esba batch retry")
            r2 = _run(model, pv[:, redo], targets[redo], angle_mode, finer, bar, size_hint=size)  # compiled when the fast path is
            s2, st2, g2, e2, m2, _ = _verify(model, pv[:, redo], r2, finer)
            good = s2 & (st2 == "stable")
            for j, i in enumerate(redo):
                if good[j] or not np.all(np.isfinite(theta[i])):
                    theta[i], tip[i], gnorm[i], eig[i], success[i], stability[i], messages[i] = (
                        r2["theta"][j], r2["tip"][j], g2[j], e2[j], s2[j], st2[j], m2[j]
                    )
                    method[i] = "newton-retry" if good[j] else "none"
            timings["retry"] = r2["fast"]
            timings["build"] += r2["build"]
            timings["compile"] += r2["compile"]

        # pseudo-arclength continuation of the load history for what is left
        redo = np.where(~(success & (stability == "stable")) & pressure_ok)[0]
        if len(redo):
            t1 = time.perf_counter()
            if bar is not None:
                bar.reset(total=len(redo))
                bar.set_description("esba batch continuation")
            for i in redo:
                if not options.fallback:
                    messages[i] = f"{messages[i]}; pseudo-arclength continuation not run (fallback=False)"
                    continue
                known = unloaded[i] if angle_mode else None
                theta[i], tip[i], success[i], stability[i], gnorm[i], eig[i], messages[i], notes[i], snapped[i] = _continue(
                    model, pv[:, i].copy(), float(P[i]), known, options
                )
                method[i] = "continuation"
                if bar is not None:
                    bar.update(1)
            timings["fallback"] = time.perf_counter() - t1
    finally:
        if bar is not None:
            bar.close()
    timings["total"] = time.perf_counter() - t_start
    with np.errstate(invalid="ignore"):
        eig_min = eig[:, 0].copy()
        eig_max = eig[:, -1].copy()
    return BatchResult(
        pressure=P,
        theta=theta,
        tip=tip,
        gradient_norm=gnorm,
        eig_min=eig_min,
        eig_max=eig_max,
        stability=np.asarray(stability).astype(str),
        success=np.asarray(success, dtype=bool),
        method=method.astype(str),
        messages=tuple(messages),
        backend=run["backend"],
        timings=timings,
        notes=tuple(notes),
        snapped=snapped,
    )


# ---------------------------------------------------------------------------------------------
# solving scenes


def solve_scenes(scenes: Sequence[Scene], options: BatchOptions | None = None) -> BatchResult:
    """Equilibria of many scenes: grouped by model and by how the pressure is set, then batched.

    All scenes must have the same segment count (the result's ``theta`` is one array); their
    effects may differ (each group gets its own model). The answers agree with
    :func:`esba.statics.equilibrium.solve` on each scene, which is also the fallback for elements the
    natural continuation cannot solve (its load history's pseudo-arclength continuation answers those).

    Raises
    ------
    BatchOptionsError
        for an empty batch or mixed segment counts.
    """
    if isinstance(scenes, Scene) or not isinstance(scenes, (list, tuple)):
        raise BatchOptionsError(f"scenes={checks.quote(scenes)}: expected a list of Scene")
    scenes = list(scenes)
    if not scenes:
        raise BatchOptionsError("scenes: the batch is empty")
    if not all(isinstance(s, Scene) for s in scenes):
        raise BatchOptionsError("scenes: expected a sequence of Scene")
    counts = sorted({s.segments for s in scenes})
    if len(counts) > 1:
        raise BatchOptionsError(f"scenes have segment counts {counts}: a batch needs one (solve one batch per n)")
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(scenes):
        groups.setdefault((s.effects, s.variant, s.pressure is None), []).append(i)
    parts = []
    for (effects, variant, angle_mode), idx in groups.items():
        model = scenes[idx[0]].model()
        rows = [scenes[i].parameters(0.0 if angle_mode else scenes[i].pressure) for i in idx]
        values = {k: np.array([r[k] for r in rows]) for k in model.parameters}
        target = np.radians([scenes[i].target_angle_deg for i in idx]) if angle_mode else None
        r = solve_arrays(model, values, target_angle=target, options=options)
        parts.append((np.asarray(idx), r))
    return _concat(parts, len(scenes))
