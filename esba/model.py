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
    check_variant,
    model_filename,
)
from derive.provenance import GENERATED_DIR, source_hash

from . import checks

__all__ = ["Model", "load_model", "cache_dir", "EffectSet", "EffectError"]

_lock = threading.Lock()

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

    def tip(self, theta, L: float) -> np.ndarray:
        """Tip pose [x, y, angle] (mm, mm, rad)."""
        return np.asarray(self.functions["kinematics"](np.asarray(theta, dtype=float), L)[0]).ravel()

    def points(self, theta, L: float) -> np.ndarray:
        """The n + 1 segment end points, shape (2, n + 1), mm."""
        return np.asarray(self.functions["kinematics"](np.asarray(theta, dtype=float), L)[1])

    def centreline(self, theta, L: float, samples: int = 101) -> np.ndarray:
        """Points [x, y, heading] at ``samples`` equally spaced fractions of L, shape (samples, 3)."""
        s = np.linspace(0.0, 1.0, samples)
        f = self.functions["centreline"].map(samples)
        out = f(np.asarray(theta, dtype=float), L, s.reshape(1, -1))
        return np.asarray(out).T

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
        for n not a whole number from 1 to :data:`esba.checks.MAX_SEGMENTS`, an unknown effect or
        variant (the message names the value).
    """
    n = checks.segments(n, EffectError)
    check_variant(variant)
    eff = EffectSet.parse(effects) if isinstance(effects, (str, list, tuple)) else effects
    if not isinstance(eff, EffectSet):
        raise EffectError(f"effects={effects!r}: expected a string such as {DEFAULT_EFFECTS!r} or an EffectSet")
    return _load(n, eff, variant)
