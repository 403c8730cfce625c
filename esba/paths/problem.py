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

__all__ = ["PathError", "PathProblem", "PARAMETERS", "ghl_function", "fold_function"]


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
# the CasADi functions of a path (per model, cached)

_GHL: dict[str, ca.Function] = {}
_FOLD: dict[str, ca.Function] = {}


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
    key = str(model.path)
    fun = _GHL.get(key)
    if fun is None:
        th, p, dp, g, h = _symbols(model)
        fun = ca.Function(
            "esba_path_ghl", [th, p, dp], [g, h, ca.jtimes(g, p, dp)], ["theta", "p", "dp"], ["g", "H", "g_lambda"], {"cse": True}
        )
        _GHL[key] = fun
    return fun


def fold_function(model: Model) -> ca.Function:
    """(theta, p, dp, v) -> H v, d(Hv)/dtheta, d(Hv)/dlambda, d2(v . g)/dlambda2 (third derivatives by AD)."""
    key = str(model.path)
    fun = _FOLD.get(key)
    if fun is None:
        th, p, dp, g, h = _symbols(model)
        v = ca.SX.sym("v", model.n)
        hv = ca.mtimes(h, v)
        vg_l = ca.jtimes(ca.dot(v, g), p, dp)
        fun = ca.Function(
            "esba_path_fold",
            [th, p, dp, v],
            [hv, ca.jacobian(hv, th), ca.jtimes(hv, p, dp), ca.jtimes(vg_l, p, dp)],
            ["theta", "p", "dp", "v"],
            ["Hv", "Hv_theta", "Hv_lambda", "vg_lambda_lambda"],
            {"cse": True},
        )
        _FOLD[key] = fun
    return fun


# ---------------------------------------------------------------------------------------------
# the problem


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
        if pressure is None:
            if scene.pressure is not None:
                pressure = scene.pressure
            else:
                pressure = pressure_for_angle(scene)
        model = scene.model()
        values = scene.parameters(pressure)
        names = model.parameters
        a = scene.actuator
        npayloads = len(scene.payloads)
        if base in ("payload", "omega", "at") and k > npayloads:
            have = f"{npayloads} payload{'s' if npayloads != 1 else ''}"
            raise PathError(f"parameter={parameter!r}: the scene has {have}; add one (--payload N) to follow its {kind.what}")
        if base == "M" and not scene.gravity:
            raise PathError("parameter='M': the mass only acts with gravity (--gravity)")
        if base == "load":
            if not (scene.payloads or scene.gravity):
                raise PathError("parameter='load': the scene has no payload and no gravity to scale")
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
        g, h, gl = ghl_function(self.model)(theta, self.params(lam), self.dp)
        h = np.asarray(h, dtype=float)
        return np.asarray(g, dtype=float).ravel(), 0.5 * (h + h.T), np.asarray(gl, dtype=float).ravel()

    def fold_terms(self, theta: np.ndarray, lam: float, v: np.ndarray):
        """H v, d(Hv)/dtheta, d(Hv)/dlambda and d2(v . g)/dlambda2 at (theta, lambda)."""
        out = fold_function(self.model)(theta, self.params(lam), self.dp, v)
        hv, hv_t, hv_l, vgll = (np.asarray(o, dtype=float) for o in out)
        return hv.ravel(), hv_t, hv_l.ravel(), float(vgll.reshape(-1)[0])

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
