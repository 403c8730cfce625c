"""Equilibria for many scenes at once: Newton continuation mapped over a batch, compiled to C.

:func:`esba.statics.equilibrium.solve` pays IPOPT's set-up and CasADi's per-call overhead (25-40 us a
call) on every solve: a few ms each. A sweep of thousands of pressures, payloads or designs of
one model is instead solved here as one CasADi ``Function`` mapped over the batch:

1. **Fast path.** Each element follows the same physical load path as :func:`solve`: from the
   unloaded state (exact for a target angle: theta_i = Theta / n with the closed-form pressure of
   :func:`esba.statics.equilibrium.pressure_for_angle`; else a pressure ramp from theta = 0), then the
   payloads and weight ramp in ``load_steps`` steps, with ``newton_steps`` Newton iterations on
   the generated gradient and Hessian at each step and ``final_steps`` more at the full load.
   Each Newton step is limited to ``max_step / n`` rad per segment and kept inside the model's
   domain (the bounds of :meth:`esba.model.generated.Model.lower_bounds`). The whole path is one graph of
   fixed size, mapped over a chunk of the batch and, when a C compiler is found, generated to C
   by CasADi and compiled once (:mod:`esba.statics.compiled`: the shared library is cached, keyed by
   the hash of the model file, the options and the graph's source, with a checksum that is
   verified before the library is loaded: a damaged one is reported and rebuilt, see
   :mod:`esba.infra.cache`). The settings are one frozen :class:`esba.statics.batch_options.BatchOptions`.
2. **Verification.** Every element is checked the way :func:`solve` checks its answers, from the
   gradient and Hessian evaluated at the final angles: finite, ``max |dU/dtheta| <=
   stationarity_tol``, not on the domain boundary, and a stability verdict from the Hessian's
   eigenvalues (:func:`esba.statics.equilibrium.stability_verdict`).
3. **Retry, then IPOPT.** Elements that fail are retried with a denser continuation (``retry``),
   and those that still fail are solved one by one with :func:`esba.statics.equilibrium.solve` when a
   scene is available (``fallback``). Every element ends with ``success``, ``stability``,
   ``ok`` and a ``message`` saying why it is not ok; no element is dropped and none is a silent NaN.

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
from typing import Callable, Mapping, Sequence

import numpy as np

from esba.infra.interrupts import interrupts_raised
from esba.infra.threads import single_threaded
from esba.model.generated import Model, domain_lower_bound, near_domain_bound
from esba.model.scene import Scene, SceneError
from esba.solvers.newton import CONTRACTION

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
from .equilibrium import EquilibriumError, solve, stability_verdicts

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

#: How an element's answer was found: the fast path, its denser retry, IPOPT, or not at all.
METHODS = ("newton", "newton-retry", "ipopt", "none")


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
        What happened on the way (a jump or a buckling on the load path, noted by the path
        solver that answered the element), per element.
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


def _run(model: Model, pv: np.ndarray, targets: np.ndarray, angle_mode: bool, options: BatchOptions, bar, size_hint: int = 0) -> dict:
    (fun_big, fun_small), backend, build_s, compile_s = mapped_functions(model, options, angle_mode, max(pv.shape[1], size_hint))
    n, size = model.n, pv.shape[1]
    outs = {k: [] for k in ("theta", "P", "grad", "hess", "tip", "min_pivot", "contraction")}
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
        "backend": backend,
        "build": build_s,
        "compile": compile_s,
        "fast": time.perf_counter() - t0,
    }


def _verify(model: Model, pv: np.ndarray, run: dict, angle_mode: bool, options: BatchOptions):
    """success, stability, gradient norm, eigenvalues and messages of a fast-path run."""
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
        stationary = gnorm <= options.stationarity_tol
        left = ~(run["min_pivot"] >= -options.unstable_tol)
        slid = ~(run["contraction"] <= CONTRACTION)
        success = finite & stationary & ~near & pressure_ok & ~left & ~slid
    messages = [""] * len(P)
    for i in np.flatnonzero(~(success & (stability == "stable"))):
        if not pressure_ok[i]:
            messages[i] = (
                f"target angle: would need a negative pressure ({P[i]:.4g} MPa)" if np.isfinite(P[i]) else "target angle: outside the model's domain for this actuator"
            )
        elif not finite[i]:
            messages[i] = "the Newton path left the model's domain (non-finite values)"
        elif near[i]:
            messages[i] = "the solve stopped on the model's domain boundary (Eq. 10): not an equilibrium"
        elif left[i]:
            messages[i] = (
                f"the Hessian lost positive definiteness on the load ramp (smallest relative LDL^T pivot "
                f"{run['min_pivot'][i]:.3g}): the stable branch ended at a fold or a branch point, for the path solver to locate"
            )
        elif slid[i]:
            messages[i] = (
                f"a load step's Newton iteration did not contract (ratio {run['contraction'][i]:.3g} > {CONTRACTION:g}; "
                "infinite with one Newton step per load step): the step may have left its branch, for the path solver to decide"
            )
        elif not stationary[i]:
            messages[i] = f"max |dU/dtheta| = {gnorm[i]:.3g} N mm/rad > stationarity_tol = {options.stationarity_tol:g}"
        else:
            messages[i] = f"the equilibrium is {stability[i]}: smallest Hessian eigenvalue {eig[i, 0]:.3g} N mm/rad^2 (largest {eig[i, -1]:.3g})"
    return success, stability, gnorm, eig, messages, pressure_ok


@single_threaded
def solve_arrays(
    model: Model,
    values: Mapping[str, float | Sequence[float] | np.ndarray],
    *,
    target_angle: float | Sequence[float] | np.ndarray | None = None,
    options: BatchOptions | None = None,
    scene_of: Callable[[int], Scene] | None = None,
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
    scene_of : callable, optional
        ``scene_of(i)`` returns the :class:`Scene` of element i, for the IPOPT fallback; without
        it elements the fast path and its retry cannot solve are reported not ok.

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
    missing = [k for k in model.parameters if k not in values]
    if missing:
        raise KeyError(f"model {model.path.name} needs parameters {missing}")
    arrays = [np.atleast_1d(np.asarray(values[k], dtype=float)) for k in model.parameters]
    angle_mode = target_angle is not None
    if angle_mode:
        arrays.append(np.atleast_1d(np.asarray(target_angle, dtype=float)))
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
        success, stability, gnorm, eig, messages, pressure_ok = _verify(model, pv, run, angle_mode, options)
        method = np.where(success & (stability == "stable"), "newton", "none").astype(object)
        theta, tip, P = run["theta"], run["tip"], run["P"]
        notes: list[tuple[str, ...]] = [()] * len(P)
        timings = {"build": run["build"], "compile": run["compile"], "fast": run["fast"], "retry": 0.0, "fallback": 0.0}

        # retry the failures (that have a pressure) with a denser continuation
        redo = np.where(~(success & (stability == "stable")) & pressure_ok)[0]
        if options.retry and len(redo):
            dense = options.denser()
            if bar is not None:
                bar.reset(total=len(redo))
                bar.set_description("esba batch retry")
            r2 = _run(model, pv[:, redo], targets[redo], angle_mode, dense, bar, size_hint=size)  # compiled when the fast path is
            s2, st2, g2, e2, m2, _ = _verify(model, pv[:, redo], r2, angle_mode, dense)
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

        # IPOPT along the load path for what is left
        redo = np.where(~(success & (stability == "stable")) & pressure_ok)[0]
        if len(redo):
            t1 = time.perf_counter()
            if bar is not None:
                bar.reset(total=len(redo))
                bar.set_description("esba batch IPOPT fallback")
            for i in redo:
                if not options.fallback or scene_of is None:
                    why = "fallback=False" if not options.fallback else "no scene given"
                    messages[i] = f"fast path: {messages[i]}; IPOPT fallback not run ({why})"
                    continue
                try:
                    eq = solve(scene_of(int(i)))
                except (EquilibriumError, SceneError) as exc:  # SceneError: scales the solver cannot resolve
                    messages[i] = str(exc)
                    continue
                ev = np.asarray(eq.eigenvalues, dtype=float)
                theta[i], tip[i], P[i] = eq.theta, eq.tip, eq.pressure
                gnorm[i], eig[i], success[i], stability[i] = eq.gradient_norm, ev, eq.success, eq.stability
                messages[i] = eq.message
                notes[i] = tuple(getattr(eq, "notes", ()))
                method[i] = "ipopt"
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
    )


# ---------------------------------------------------------------------------------------------
# solving scenes


def solve_scenes(scenes: Sequence[Scene], options: BatchOptions | None = None) -> BatchResult:
    """Equilibria of many scenes: grouped by model and by how the pressure is set, then batched.

    All scenes must have the same segment count (the result's ``theta`` is one array); their
    effects may differ (each group gets its own model). The answers agree with
    :func:`esba.statics.equilibrium.solve` on each scene, which is also the fallback for elements the
    Newton path cannot solve.

    Raises
    ------
    BatchOptionsError
        for an empty batch or mixed segment counts.
    """
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
        r = solve_arrays(model, values, target_angle=target, options=options, scene_of=lambda j, idx=idx: scenes[idx[j]])
        parts.append((np.asarray(idx), r))
    return _concat(parts, len(scenes))
