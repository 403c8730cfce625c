"""What a path follows: g(theta, lambda) = dU/dtheta = 0 with the parameters affine in lambda.

A :class:`PathProblem` holds one generated model, the parameter vector as a function of lambda
(p = p0 + lambda dp), lambda's name, unit, physical range and typical size, and evaluates what the
path engine (:mod:`esba.paths.continuation`) needs: the generated gradient g and Hessian H, dg/dlambda by CasADi's
forward AD of the generated gradient along dp, and for folds and branch points the third
derivatives d(H v)/d(theta, lambda) by AD.

The scene parameters a path can follow are :data:`PARAMETERS` (:meth:`PathProblem.from_scene`);
:meth:`PathProblem.homotopy` goes from one parameter set to another (the load factor of a solve).

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> p = PathProblem.from_scene(MAIN_JOB, "omega")
>>> p.name, p.unit, p.lam0, p.domain
('omega1', 'deg', 90.0, (-inf, inf))
>>> PathProblem.from_scene(MAIN_JOB, "payload2")
Traceback (most recent call last):
...
esba.paths.problem.PathError: parameter='payload2': the scene has 1 payload; add one (--payload N) to follow its payload magnitude
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from esba.infra.errors import InputError
from esba.model.closed_form import pressure_for_angle
from esba.model.generated import Model, domain_lower_bound
from esba.model.scene import Scene, SceneError
from esba.solvers.native import Kernel, packed

__all__ = ["PathError", "PathProblem", "PARAMETERS", "ghl_function", "fold_function", "is_path_problem"]


class PathError(InputError):
    """A path that cannot be set up: the message names the parameter or option, the value and what is allowed."""


# ---------------------------------------------------------------------------------------------
# the parameters a scene can be traced in


@dataclass(frozen=True)
class _Kind:
    model: str  # model parameter name (with {k} for a payload's)
    unit: str
    to_model: float  # model value = user value * to_model
    scale: float  # typical size, user unit
    low: float  # the physical range in the user unit (see from_scene for the geometric ones)
    high: float
    open_low: bool = False  # the end itself is outside (r2 > 0): the trace stops just inside it
    open_high: bool = False
    period: float | None = None
    what: str = ""


#: The scene parameters a path can follow: name -> (model parameter, unit, conversion, typical
#: size, physical range). A payload's parameters take its number: ``payload2``, ``omega2``, ``at2``
#: (``payload`` = ``payload1``). ``load`` scales every payload and the weight together.
PARAMETERS: dict[str, _Kind] = {
    "pressure": _Kind("P", "MPa", 1.0, 0.1, 0.0, math.inf, what="pressure"),
    "payload": _Kind("F{k}", "N", 1.0, 1.0, 0.0, math.inf, what="payload magnitude"),
    "omega": _Kind("Omega{k}", "deg", math.pi / 180.0, 45.0, -math.inf, math.inf, period=360.0, what="payload direction from the vertical"),
    "at": _Kind("s{k}", "1 (fraction of L)", 1.0, 0.1, 0.0, 1.0, open_low=True, what="payload point"),
    "load": _Kind("", "1 (load factor)", 1.0, 1.0, 0.0, math.inf, what="factor on every payload and the weight"),
    "r2": _Kind("r2", "mm", 1.0, 1.0, 0.0, math.inf, open_low=True, open_high=True, what="chamber radius"),
    "d": _Kind("d", "mm", 1.0, 1.0, 0.0, math.inf, open_high=True, what="eccentric distance"),
    "rho": _Kind("rho", "deg", math.pi / 180.0, 10.0, 0.0, 90.0, open_high=True, what="fibre angle"),
    "E": _Kind("E", "MPa", 1.0, 0.1, 0.0, math.inf, open_low=True, what="Young's modulus"),
    "L": _Kind("L", "mm", 1.0, 10.0, 0.0, math.inf, open_low=True, what="length"),
    "r1": _Kind("r1", "mm", 1.0, 1.0, 0.0, math.inf, open_low=True, what="external radius"),
    "M": _Kind("M", "kg", 1.0, 0.01, 0.0, math.inf, what="mass (with gravity)"),
}

#: How far inside an open end of the physical range a trace stops (relative to the typical size).
OPEN_END_INSET = 1e-6


def _split_name(name: str) -> tuple[str, int]:
    """``"omega2"`` -> ("omega", 2); ``"payload"`` -> ("payload", 1)."""
    if not isinstance(name, str):
        raise PathError(f"parameter={name!r}: allowed are {', '.join(PARAMETERS)} (a payload's with its number, e.g. payload2)")
    if name in PARAMETERS:
        return name, 1
    base = name.rstrip("0123456789")
    digits = name[len(base) :]
    if not digits or base not in ("payload", "omega", "at"):
        raise PathError(f"parameter={name!r}: allowed are {', '.join(PARAMETERS)} (a payload's with its number, e.g. payload2)")
    k = int(digits) if digits else 1
    if k < 1:
        raise PathError(f"parameter={name!r}: payloads are numbered from 1")
    return base, k


# ---------------------------------------------------------------------------------------------
# the CasADi functions of a path (in the model's registry)


def _symbols(model: Model):
    n, npar = model.n, len(model.parameters)
    th = ca.SX.sym("theta", n)
    p = ca.SX.sym("p", npar)
    dp = ca.SX.sym("dp", npar)
    args = ca.vertsplit(p) if npar else []
    return th, p, dp, model["gradient"](th, *args), model["hessian"](th, *args)


def ghl_function(model: Model) -> ca.Function:
    """(theta, p, dp) -> g, H, dg/dp . dp: the generated gradient and Hessian and the gradient's
    derivative along a parameter direction (CasADi forward AD of the generated gradient)."""

    def build() -> ca.Function:
        th, p, dp, g, h = _symbols(model)
        return ca.Function("esba_path_ghl", [th, p, dp], [g, h, ca.jtimes(g, p, dp)], ["theta", "p", "dp"], ["g", "H", "g_lambda"], {"cse": True})

    return model.derived("path_ghl", build, builder_files=(__file__,))


def fold_function(model: Model) -> ca.Function:
    """(theta, p, dp, v) -> g, H, dg/dlambda, H v, d(Hv)/dtheta, d(Hv)/dlambda, d2(v . g)/dlambda2:
    everything an extended system (folds, branch points) needs at one point, third derivatives by AD."""

    def build() -> ca.Function:
        th, p, dp, g, h = _symbols(model)
        v = ca.SX.sym("v", model.n)
        hv = ca.mtimes(h, v)
        vg_l = ca.jtimes(ca.dot(v, g), p, dp)
        return ca.Function(
            "esba_path_fold",
            [th, p, dp, v],
            [g, h, ca.jtimes(g, p, dp), hv, ca.jacobian(hv, th), ca.jtimes(hv, p, dp), ca.jtimes(vg_l, p, dp)],
            ["theta", "p", "dp", "v"],
            ["g", "H", "g_lambda", "Hv", "Hv_theta", "Hv_lambda", "vg_lambda_lambda"],
            {"cse": True},
        )

    return model.derived("path_fold", build, builder_files=(__file__,))


#: Up to this n the dense terms (g, H, dg/dlambda; the extended system's third derivatives) run
#: compiled; beyond it their n x n outputs cost as much as CasADi's interpreter, and gcc takes
#: seconds (g, H: 9 s at n = 100) to a minute (the extended system's Jacobian).
DENSE_COMPILE_MAX_N = 32


def _packed_kernel(model: Model, which: str):
    """The ``ghl`` or ``fold`` Function of ``model`` with its inputs and outputs packed into one vector
    each, as a :class:`esba.solvers.native.Kernel` (compiled when it pays)."""

    def build():
        fun = ghl_function(model) if which == "ghl" else fold_function(model)
        mode = "auto" if model.n <= DENSE_COMPILE_MAX_N else "never"
        return Kernel(packed(fun, f"esba_path_{which}_packed"), mode, model.n)

    return model.derived(f"path_{which}_kernel", build, persist=False)


#: Points per call of the mapped Hessian (:meth:`PathProblem.hessians`); the last call is padded.
HESSIAN_CHUNK = 32


def _hessian_map(model: Model) -> ca.Function:
    def build() -> ca.Function:
        th, p, _, _, h = _symbols(model)
        one = ca.Function("esba_path_hessian", [th, p], [ca.vec(0.5 * (h + h.T))], {"cse": True})
        return one.map(HESSIAN_CHUNK, "serial")

    return model.derived("path_hessian_map", build, persist=False)


# ---------------------------------------------------------------------------------------------
# the problem


#: What the engine asks of a problem besides a :class:`PathProblem`: a problem of another model
#: (:class:`esba.statics.spatial_paths.SpatialPathProblem`) answers these and brings its own
#: corrector kernels (``corrector_kernels``), since the planar ones use the chain's Hessian structure.
PROBLEM_INTERFACE = ("n", "p0", "dp", "name", "unit", "domain", "scale", "period", "ghl", "extended_terms", "fold_terms", "hessians",
                     "tips", "tip", "lower_bound", "in_range", "defined", "describe", "unit_short", "corrector_kernels", "minimum")


def is_path_problem(problem) -> bool:
    """A :class:`PathProblem`, or an object that answers all of :data:`PROBLEM_INTERFACE`."""
    return isinstance(problem, PathProblem) or all(hasattr(problem, k) for k in PROBLEM_INTERFACE)


@dataclass(frozen=True, eq=False)
class PathProblem:
    """g(theta, lambda) = 0 of one model with the parameters affine in lambda: p = p0 + lambda dp.

    Build one with :meth:`from_scene` (one scene parameter, lambda in its unit, e.g. degrees for a
    direction) or :meth:`homotopy` (lambda from 0 at one parameter set to 1 at another).

    Attributes
    ----------
    model : Model
        The generated model.
    p0, dp : ndarray
        Model parameter values at lambda = 0 and their change per unit of lambda (model units).
    name, unit : str
        What lambda is and its unit, e.g. ``payload1`` and ``N``.
    domain : (float, float)
        The values of lambda for which the model is defined (a design-space edge, P >= 0, ...).
    scale : float
        A typical size of lambda (sigma of the arclength) when the trace gives none.
    period : float or None
        Lambda is periodic (a direction: 360 degrees): "returning to the start" compares modulo it.
    scene : Scene or None
        The scene at ``lam0`` (for :meth:`scene_at`), when built from one.
    lam0 : float
        The scene's own value of lambda.
    """

    model: Model
    p0: np.ndarray
    dp: np.ndarray
    name: str
    unit: str
    domain: tuple[float, float] = (-math.inf, math.inf)
    scale: float = 1.0
    period: float | None = None
    scene: Scene | None = None
    lam0: float = 0.0
    pressure: float | None = None
    what: str = ""

    # -- constructors ------------------------------------------------------------------------

    @classmethod
    def homotopy(cls, model: Model, p_from: np.ndarray, p_to: np.ndarray, name: str = "load factor", what: str = "") -> PathProblem:
        """lambda = 0 at ``p_from``, 1 at ``p_to`` (model parameter vectors), domain [0, inf)."""
        p_from = np.asarray(p_from, dtype=float)
        p_to = np.asarray(p_to, dtype=float)
        return cls(model, p_from, p_to - p_from, name, "1", (0.0, math.inf), 1.0, what=what or name)

    @classmethod
    def from_scene(cls, scene: Scene, parameter: str, *, pressure: float | None = None) -> PathProblem:
        """Follow ``parameter`` of ``scene`` (see :data:`PARAMETERS`); the others stay at the scene's values.

        Parameters
        ----------
        scene : Scene
            The base scene; its pressure comes from its target angle when it gives no pressure
            (or pass ``pressure``).
        parameter : str
            ``pressure``, ``payload``/``payloadK``, ``omega``/``omegaK``, ``at``/``atK``, ``load``,
            ``r2``, ``d``, ``rho``, ``E``, ``L``, ``r1``, ``M``.
        pressure : float, optional
            The pressure (MPa) when the scene gives a target angle (saves the closed form).
        """
        if not isinstance(scene, Scene):
            raise PathError(f"scene={scene!r}: expected a Scene")
        base, k = _split_name(parameter)
        kind = PARAMETERS[base]
        # what the scene cannot follow is refused before any model is loaded (or generated)
        npayloads = len(scene.payloads)
        if base in ("payload", "omega", "at") and k > npayloads:
            have = f"{npayloads} payload{'s' if npayloads != 1 else ''}"
            raise PathError(f"parameter={parameter!r}: the scene has {have}; add one (--payload N) to follow its {kind.what}")
        if base == "M" and not scene.gravity:
            raise PathError("parameter='M': the mass only acts with gravity (--gravity)")
        if base == "load" and not (scene.payloads or scene.gravity):
            raise PathError("parameter='load': the scene has no payload and no gravity to scale")
        if pressure is None:
            if scene.pressure is not None:
                pressure = scene.pressure
            else:
                pressure = pressure_for_angle(scene)
        model = scene.model()
        values = scene.parameters(pressure)
        names = model.parameters
        a = scene.actuator
        if base == "load":
            unloaded = model.param_vector(scene.parameters(pressure, load_factor=0.0))
            full = model.param_vector(values)
            return cls(
                model, unloaded, full - unloaded, "load", kind.unit, (0.0, math.inf), kind.scale, None, scene, 1.0, pressure, kind.what
            )
        mname = kind.model.format(k=k)
        label = f"{base}{k}" if base in ("payload", "omega", "at") else base
        if base == "pressure":
            lam0 = float(pressure)
        elif base == "payload":
            lam0 = scene.payloads[k - 1].force
        elif base == "omega":
            lam0 = scene.payloads[k - 1].angle_deg
        elif base == "at":
            lam0 = scene.payloads[k - 1].at
        elif base == "rho":
            lam0 = a.rho_deg
        else:
            lam0 = float(getattr(a, base))
        low, high = kind.low, kind.high
        if base == "r2":
            high = a.r1 - a.d
        elif base == "d":
            high = a.r1 - a.r2
        elif base == "r1":
            low = a.r2 + a.d
        inset = OPEN_END_INSET * kind.scale
        low = low + inset if kind.open_low else low
        high = high - inset if kind.open_high else high
        i = names.index(mname)
        p0 = model.param_vector(values)
        p0[i] = 0.0
        dp = np.zeros(len(names))
        dp[i] = kind.to_model
        return cls(model, p0, dp, label, kind.unit, (low, high), kind.scale, kind.period, scene, float(lam0), float(pressure), kind.what)

    # -- evaluation --------------------------------------------------------------------------

    @property
    def n(self) -> int:
        """Segment count."""
        return self.model.n

    def params(self, lam: float) -> np.ndarray:
        """The model parameter vector at lambda."""
        return self.p0 + lam * self.dp

    def ghl(self, theta: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """g, H (symmetrised) and dg/dlambda at (theta, lambda)."""
        n = self.n
        out = _packed_kernel(self.model, "ghl")(np.concatenate([theta, self.params(lam), self.dp]))
        h = out[n : n + n * n].reshape(n, n)
        return out[:n], 0.5 * (h + h.T), out[n + n * n :]

    def extended_terms(self, theta: np.ndarray, lam: float, v: np.ndarray):
        """g, H (symmetrised), dg/dlambda, H v, d(Hv)/dtheta, d(Hv)/dlambda and d2(v . g)/dlambda2 at
        (theta, lambda), in one call: what Newton on an extended system needs per iteration."""
        n = self.n
        out = _packed_kernel(self.model, "fold")(np.concatenate([theta, self.params(lam), self.dp, v]))
        g, h, gl = out[:n], out[n : n + n * n].reshape(n, n), out[n + n * n : 2 * n + n * n]
        at = 2 * n + n * n
        hv, hv_t, hv_l = out[at : at + n], out[at + n : at + n + n * n].reshape(n, n, order="F"), out[at + n + n * n : at + 2 * n + n * n]
        return g, 0.5 * (h + h.T), gl, hv, hv_t, hv_l, float(out[-1])

    def fold_terms(self, theta: np.ndarray, lam: float, v: np.ndarray):
        """H v, d(Hv)/dtheta, d(Hv)/dlambda and d2(v . g)/dlambda2 at (theta, lambda)."""
        return self.extended_terms(theta, lam, v)[3:]

    def hessians(self, theta: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """The symmetrised Hessians of many points, shape (m, n, n), in mapped calls."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        lam = np.asarray(lam, dtype=float).ravel()
        m, n = theta.shape
        out = np.empty((m, n, n))
        fun = _hessian_map(self.model)
        for start in range(0, m, HESSIAN_CHUNK):
            stop = min(m, start + HESSIAN_CHUNK)
            th = np.zeros((n, HESSIAN_CHUNK))
            th[:, : stop - start] = theta[start:stop].T
            th[:, stop - start :] = theta[stop - 1][:, None]
            lams = np.concatenate([lam[start:stop], np.full(HESSIAN_CHUNK - (stop - start), lam[stop - 1])])
            p = self.p0[:, None] + lams[None, :] * self.dp[:, None]
            h = np.asarray(fun(th, p), dtype=float)
            out[start:stop] = h[:, : stop - start].T.reshape(stop - start, n, n)
        return out

    def tips(self, theta: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Tip [x, y, angle] of many points, shape (m, 3) (NumPy, :meth:`esba.model.generated.Model.tips`)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        lam = np.asarray(lam, dtype=float).ravel()
        i = self.model.parameters.index("L")
        lengths = self.p0[i] + lam * self.dp[i]
        if np.all(lengths == lengths[0]):
            return self.model.tips(theta, lengths[0]) if len(theta) else np.zeros((0, 3))
        return np.vstack([self.model.tips(t[None, :], L) for t, L in zip(theta, lengths)])

    def _geometry(self, lam: float) -> tuple[float, float, float, float]:
        p = self.params(lam)
        names = self.model.parameters
        return tuple(float(p[names.index(k)]) for k in ("L", "r1", "r2", "d"))  # type: ignore[return-value]

    def lower_bound(self, lam: float) -> float:
        """The lowest segment angle of the model's domain at lambda (Eq. 10), rad."""
        return float(domain_lower_bound(self.n, *self._geometry(lam)))

    def tip(self, theta: np.ndarray, lam: float) -> np.ndarray:
        """Tip [x, y, angle] at (theta, lambda)."""
        return self.model.tip(theta, self._geometry(lam)[0])

    def in_range(self, lam: float) -> bool:
        """lambda lies in the parameter's physical range (:attr:`domain`)."""
        return bool(math.isfinite(lam) and self.domain[0] <= lam <= self.domain[1])

    def defined(self, theta: np.ndarray, lam: float) -> bool:
        """The model is defined at (theta, lambda): finite values, a real geometry, theta inside Eq. 10's domain.

        Lambda may lie outside the physical range here (a corrector iterate may step past P = 0):
        the trace stops exactly on the range's ends instead.
        """
        if not (math.isfinite(lam) and np.all(np.isfinite(theta))):
            return False
        L, r1, r2, d = self._geometry(lam)
        if not (L > 0 and r1 > 0 and r2 > 0 and d > -r1 and r2 + d < r1):
            return False
        return bool(np.all(theta > domain_lower_bound(self.n, L, r1, r2, d)))

    def scene_at(self, lam: float) -> Scene:
        """The scene with the parameter at lambda (needs a problem built from a scene)."""
        if self.scene is None:
            raise PathError(f"the path in {self.name} was not built from a scene")
        s = self.scene
        base, k = _split_name(self.name) if self.name in PARAMETERS or self.name.rstrip("0123456789") in PARAMETERS else (self.name, 1)
        try:
            if base == "pressure":
                return s.replace(pressure=float(lam))
            if base == "load":  # no weight at all at a load factor of 0 (the scene's g must stay > 0)
                return s.replace(payloads=tuple(p.scaled(lam) for p in s.payloads), g=s.g * lam if lam > 0 else s.g, gravity=s.gravity and lam > 0)
            if base in ("payload", "omega", "at"):
                payloads = list(s.payloads)
                p = payloads[k - 1]
                field_name = {"payload": "force", "omega": "angle_deg", "at": "at"}[base]
                payloads[k - 1] = replace(p, **{field_name: float(lam)})
                return s.replace(payloads=tuple(payloads))
            if base == "rho":
                return s.replace(rho_deg=float(lam))
            return s.replace(**{base: float(lam)})
        except SceneError as exc:
            raise PathError(f"{self.name}={lam:g} {self.unit}: {exc}") from None

    @property
    def unit_short(self) -> str:
        """The unit without its explanation, " MPa" with a leading space, or "" for a plain number."""
        unit = self.unit.split(" ")[0]
        return "" if unit == "1" else f" {unit}"

    def describe(self, lam: float) -> str:
        """``payload1 = 2 N``."""
        unit = self.unit.split(" ")[0]
        return f"{self.name} = {lam:.6g}" + ("" if unit == "1" else f" {unit}")
