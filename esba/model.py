"""Load generated models: the only contract between ``derive`` and the runtime.

A model is a set of CasADi Functions with named inputs and outputs (see any file in
``generated/``):

==========  =====================================  =====================================
Function    inputs                                 outputs
==========  =====================================  =====================================
energy      theta, *PARAMETERS                     U (N*mm), terms (one per TERMS entry)
gradient    theta, *PARAMETERS                     grad (n)
hessian     theta, *PARAMETERS                     hess (n x n)
kinematics  theta, L                               tip [x, y, angle], points (2 x (n+1))
centreline  theta, L, s                            point [x, y, heading] at fraction s
==========  =====================================  =====================================

Models are found in the committed ``generated/`` package first, then in a per-user cache
(``$ESBA_CACHE_DIR``, else ``$XDG_CACHE_HOME/esba``, else ``~/.cache/esba``), keyed by the hash of
the derivation source. A model found in neither is generated on demand (this is the only place
the runtime imports SymPy) and written atomically, so two processes generating the same model
both end with the same complete file.
"""

from __future__ import annotations

import importlib.util
import json
import os
import threading
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Mapping

import casadi as ca
import numpy as np

from derive.effects import (
    DEFAULT_EFFECTS,
    DEFAULT_VARIANT,
    EffectError,
    EffectSet,
    check_segments,
    check_variant,
    model_filename,
)
from derive.provenance import GENERATED_DIR, source_hash

__all__ = ["Model", "load_model", "cache_dir", "domain_lower_bound", "near_domain_bound", "EffectSet", "EffectError"]

_lock = threading.Lock()

#: The combined Function of :meth:`Model.state`, per model file.
_STATE: dict[str, ca.Function] = {}

#: Relative distance kept from the edge of the model's domain.
DOMAIN_MARGIN = 1e-6


def cache_dir() -> Path:
    """Folder of models generated on demand for this derivation source."""
    root = os.environ.get("ESBA_CACHE_DIR")
    if root:
        base = Path(root)
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (Path(xdg) if xdg else Path.home() / ".cache") / "esba"
    return base / "models" / source_hash()[:16]


def _committed(filename: str) -> Path | None:
    path = GENERATED_DIR / filename
    if not path.exists():
        return None
    manifest = GENERATED_DIR / "manifest.json"
    if manifest.exists():
        entry = json.loads(manifest.read_text(encoding="utf-8")).get("models", {}).get(filename)
        # a committed model of an older derivation is not served: regenerate it into the cache
        if entry is not None and entry.get("source_sha256") != source_hash():
            return None
    return path


def _exec_model(path: Path) -> dict[str, ca.Function]:
    spec = importlib.util.spec_from_file_location(f"esba_model_{path.stem}", path)
    if spec is None or spec.loader is None:  # pragma: no cover - a broken file system
        raise RuntimeError(f"cannot load model file {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build()


@dataclass(frozen=True)
class Model:
    """The CasADi Functions of one (n, effects, variant) model.

    Examples
    --------
    >>> m = load_model(3)
    >>> m.parameters
    ('L', 'r1', 'r2', 'd', 'rho', 'E', 'P', 'F1', 'Omega1', 's1')
    >>> tip = m.tip([0.0, 0.0, 0.0], L=135.0)
    >>> [round(float(v), 6) for v in tip]
    [135.0, 0.0, 0.0]
    """

    n: int
    effects: EffectSet
    variant: str
    path: Path
    functions: Mapping[str, ca.Function]

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of the parameter inputs, in the order the Functions take them after theta."""
        return self.effects.parameters()

    @property
    def terms(self) -> tuple[str, ...]:
        """Names of the energy terms, in the order of the ``terms`` output."""
        return self.effects.terms()

    def __getitem__(self, name: str) -> ca.Function:
        return self.functions[name]

    def param_vector(self, values: Mapping[str, float]) -> np.ndarray:
        """The parameter values in the model's order; every name in :attr:`parameters` is needed."""
        missing = [p for p in self.parameters if p not in values]
        if missing:
            raise KeyError(f"model {self.path.name} needs parameters {missing}")
        return np.array([float(values[p]) for p in self.parameters])

    def _call(self, fname: str, theta, params) -> list:
        p = params if isinstance(params, np.ndarray) else self.param_vector(params)
        return self.functions[fname](np.asarray(theta, dtype=float), *p)

    def energy(self, theta, params) -> float:
        """Total potential energy U (N*mm)."""
        return float(self._call("energy", theta, params)[0])

    def energy_terms(self, theta, params) -> dict[str, float]:
        """Each term of U by name (N*mm)."""
        vals = np.asarray(self._call("energy", theta, params)[1]).ravel()
        return dict(zip(self.terms, map(float, vals)))

    def gradient(self, theta, params) -> np.ndarray:
        """dU/dtheta (N*mm/rad)."""
        return np.asarray(self._call("gradient", theta, params)).ravel()

    def hessian(self, theta, params) -> np.ndarray:
        """d2U/dtheta2 (N*mm/rad^2)."""
        return np.asarray(self._call("hessian", theta, params))

    def state(self, theta, params) -> dict[str, np.ndarray | float | dict]:
        """U, its terms, gradient, Hessian, tip and segment end points at theta, in one call.

        Keys ``energy`` (N*mm), ``terms`` (by name), ``gradient``, ``hessian``, ``tip`` and
        ``points`` (as the single-purpose methods return them).
        """
        p = params if isinstance(params, np.ndarray) else self.param_vector(params)
        fun = _STATE.get(str(self.path))
        if fun is None:
            th = ca.SX.sym("theta", self.n)
            ps = ca.SX.sym("p", len(self.parameters))
            args = ca.vertsplit(ps) if len(self.parameters) else []
            u, terms = self.functions["energy"](th, *args)
            length = ps[self.parameters.index("L")]
            tip, points = self.functions["kinematics"](th, length)
            outs = [u, terms, self.functions["gradient"](th, *args), self.functions["hessian"](th, *args), tip, points]
            fun = _STATE[str(self.path)] = ca.Function("esba_state", [th, ps], outs, {"cse": True})
        u, terms, g, h, tip, points = fun(np.asarray(theta, dtype=float), p)
        return {
            "energy": float(u),
            "terms": dict(zip(self.terms, map(float, np.asarray(terms).ravel()))),
            "gradient": np.asarray(g).ravel(),
            "hessian": np.asarray(h),
            "tip": np.asarray(tip).ravel(),
            "points": np.asarray(points),
        }

    def tip(self, theta, L: float) -> np.ndarray:
        """Tip pose [x, y, angle] (mm, mm, rad)."""
        return np.asarray(self.functions["kinematics"](np.asarray(theta, dtype=float), L)[0]).ravel()

    def points(self, theta, L: float) -> np.ndarray:
        """The n + 1 segment end points, shape (2, n + 1), mm."""
        return np.asarray(self.functions["kinematics"](np.asarray(theta, dtype=float), L)[1])

    def centreline(self, theta, L: float, samples: int = 101, points: np.ndarray | None = None) -> np.ndarray:
        """Points [x, y, heading] at ``samples`` equally spaced fractions of L, shape (samples, 3).

        Each segment is a circular arc (Eq. 1): the point at fraction sigma of segment i is
        p_i + R(phi_i) (L/n) sigma [sinc(sigma theta_i), versinc(sigma theta_i)], heading
        phi_i + sigma theta_i, from the segment end points of the generated ``kinematics``; NumPy
        does the sampling (the generated ``centreline`` Function gives the same points one at a time).
        """
        theta = np.asarray(theta, dtype=float).ravel()
        n = self.n
        ends = self.points(theta, L) if points is None else points  # (2, n + 1)
        s = np.linspace(0.0, 1.0, samples)
        seg = np.minimum((s * n).astype(int), n - 1)
        sigma = s * n - seg
        phi = np.concatenate([[0.0], np.cumsum(theta)])[seg]
        u = sigma * theta[seg]
        sinc = np.sinc(u / np.pi)
        versinc = 0.5 * u * np.sinc(u / (2.0 * np.pi)) ** 2
        length = (L / n) * sigma
        cx, cy = length * sinc, length * versinc
        x = ends[0, seg] + np.cos(phi) * cx - np.sin(phi) * cy
        y = ends[1, seg] + np.sin(phi) * cx + np.cos(phi) * cy
        return np.column_stack([x, y, phi + u])

    def lower_bounds(self, values: Mapping[str, float], margin: float = DOMAIN_MARGIN) -> np.ndarray:
        """The model's domain as bounds on theta: :func:`domain_lower_bound` for every segment."""
        L, r1, r2, d = (float(values[k]) for k in ("L", "r1", "r2", "d"))
        return np.full(self.n, domain_lower_bound(self.n, L, r1, r2, d, margin))


def domain_lower_bound(n: int, L, r1, r2, d, margin: float = DOMAIN_MARGIN, maximum=np.maximum):
    """The lowest segment angle of the model's domain (always < 0), for floats, arrays or symbols.

    ``L r2^2 + n r1^3 theta_i >= 0`` (the square root of Eq. 10) and ``L + n (r1 + d) theta_i > 0``
    (its denominator), kept ``margin`` (relative) inside. ``maximum`` is ``np.maximum`` for
    numbers and arrays, ``casadi.fmax`` for CasADi expressions.

    >>> round(float(domain_lower_bound(3, 135.0, 8.0, 3.0, 4.0)), 6)
    -0.791015
    """
    return maximum(-L * r2**2 / (n * r1**3), -L / (n * (r1 + d))) * (1.0 - margin)


def near_domain_bound(theta, lbx, axis: int | None = None):
    """True where theta lies on (within 1e-7 relative of) the model's lower bounds ``lbx``: a solve that
    stops there has met the edge of Eq. 10's domain, not an equilibrium. ``axis`` reduces over it
    (e.g. ``axis=1`` for a batch of rows); None reduces everything to one bool.

    >>> bool(near_domain_bound(np.array([0.1, -0.5]), np.array([-0.5, -0.5])))
    True
    """
    theta, lbx = np.asarray(theta, dtype=float), np.asarray(lbx, dtype=float)
    close = theta - lbx <= 1e-7 * np.maximum(1.0, np.abs(lbx))
    return bool(np.any(close)) if axis is None else np.any(close, axis=axis)


def _locate_or_generate(n: int, effects: EffectSet, variant: str) -> Path:
    filename = model_filename(n, effects, variant)
    path = _committed(filename)
    if path is not None:
        return path
    cached = cache_dir() / filename
    if cached.exists():
        return cached
    with _lock:
        if cached.exists():
            return cached
        from derive.emit import write_model  # SymPy is imported only here

        write_model(n, effects, variant, cached.parent, manifest=False)
    return cached


@lru_cache(maxsize=64)
def _load(n: int, effects: EffectSet, variant: str) -> Model:
    path = _locate_or_generate(n, effects, variant)
    return Model(n, effects, variant, path, _exec_model(path))


def load_model(n: int = 3, effects: EffectSet | str = DEFAULT_EFFECTS, variant: str = DEFAULT_VARIANT) -> Model:
    """The model for ``n`` segments with ``effects`` and ``variant``, generated if missing.

    Raises
    ------
    EffectError
        for n < 1 or not whole, an unknown effect or variant (the message names the value).
    """
    n = check_segments(n)
    check_variant(variant)
    eff = EffectSet.parse(effects) if isinstance(effects, (str, list, tuple)) else effects
    if not isinstance(eff, EffectSet):
        raise EffectError(f"effects={effects!r}: expected a string such as {DEFAULT_EFFECTS!r} or an EffectSet")
    return _load(n, eff, variant)
