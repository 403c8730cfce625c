"""Uncertain parameters: a standard deviation (or a tolerance) for any scene parameter of
:mod:`esba.analysis.sensitivity`, from ``--sigma NAME=SIGMA`` or a scene file's ``[uncertainty]`` table.

``E=0.05`` is a standard deviation in the parameter's scene-file unit (MPa here), ``E=10%`` one
relative to its value, ``±t`` (also ``+-t``, ``±10%``) a tolerance: uniform on [-t, t], so sigma =
t / sqrt(3) (the GUM's rectangular distribution). :func:`resolve_sigmas` makes them absolute for a
scene. :mod:`esba.calibration.uncertainty` propagates them.

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> [(s.name, round(s.sigma, 4), s.distribution) for s in resolve_sigmas(MAIN_JOB, [parse_sigma("E=10%"), parse_sigma("r2=±0.1")])]
[('r2', 0.0577, 'uniform'), ('E', 0.054, 'normal')]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from esba.analysis.sensitivity import (
    UNITS,
    SensitivityError,
    check_names,
    scene_parameters,
)
from esba.analysis.sensitivity3d import check_names3d, scene_parameters3d
from esba.infra import checks, inputs, jsonsafe
from esba.infra.errors import InputError
from esba.model.scene import Scene

__all__ = ["UncertaintyError", "SigmaSpec", "Sigma", "parse_sigma", "sigmas_from_table", "load_sigmas", "resolve_sigmas", "domain", "outside_domain"]


class UncertaintyError(InputError):
    """A sigma, tolerance or option that is not allowed: the message names it, the value and what is allowed."""


@dataclass(frozen=True)
class SigmaSpec:
    """An uncertainty as given, before it meets a scene.

    Attributes
    ----------
    name : str
        Scene parameter (``E``, ``r2``, ``rho``, ``F1``, ...).
    value : float
        Standard deviation, or the half-width t of a tolerance, > 0.
    relative : bool
        ``value`` is a fraction of the parameter's value (given with ``%``).
    distribution : str
        ``normal`` (a standard deviation) or ``uniform`` (a tolerance ±t).
    given : str
        The text as given (for messages).
    """

    name: str
    value: float
    relative: bool
    distribution: str
    given: str


@dataclass(frozen=True)
class Sigma:
    """An uncertainty resolved against a scene: absolute, in the parameter's unit.

    Attributes
    ----------
    name, unit : str
    nominal : float
        The parameter's value in the scene.
    sigma : float
        Standard deviation (for a tolerance ±t: t / sqrt(3)).
    distribution : str
        ``normal`` or ``uniform``.
    half_width : float or None
        t of a tolerance.
    given : str
    """

    name: str
    unit: str
    nominal: float
    sigma: float
    distribution: str
    half_width: float | None
    given: str

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return jsonsafe.clean(
            {"name": self.name, "unit": self.unit, "nominal": self.nominal, "sigma": self.sigma,
             "distribution": self.distribution, "half_width": self.half_width, "given": self.given}
        )


def parse_sigma(text: str, where: str = "--sigma") -> SigmaSpec:
    """``NAME=VALUE`` with VALUE ``0.05``, ``10%``, ``±0.1``, ``+-0.1`` or ``±10%``.

    >>> parse_sigma("r2=±0.1")
    SigmaSpec(name='r2', value=0.1, relative=False, distribution='uniform', given='r2=±0.1')
    >>> parse_sigma("E=-1")
    Traceback (most recent call last):
    ...
    esba.calibration.sigmas.UncertaintyError: --sigma 'E=-1': expected NAME=SIGMA with SIGMA > 0 (0.05, 10%, ±0.1 or ±10%)
    """
    if not isinstance(text, str) or text.count("=") != 1:
        raise UncertaintyError(f"{where} {checks.quote(text)}: expected NAME=SIGMA, e.g. E=0.05, E=10%, r2=±0.1")
    name, raw = (s.strip() for s in text.split("="))
    return _spec(name, raw, where, text)


def _spec(name: str, raw: Any, where: str, given: str) -> SigmaSpec:
    bad = UncertaintyError(f"{where} {checks.quote(given)}: expected NAME=SIGMA with SIGMA > 0 (0.05, 10%, ±0.1 or ±10%)")
    if not name:
        raise bad
    if isinstance(raw, bool):
        raise bad
    if isinstance(raw, (int, float)):
        value, relative, dist = float(raw), False, "normal"
    elif isinstance(raw, str):
        s = raw.strip()
        dist = "normal"
        for prefix in ("±", "+-", "+/-"):
            if s.startswith(prefix):
                s, dist = s[len(prefix):].strip(), "uniform"
                break
        relative = s.endswith("%")
        if relative:
            s = s[:-1].strip()
        try:
            value = checks.number(name, s)  # decimal ASCII digits, as every number flag (float() takes 1_0 and other scripts' digits)
        except ValueError:
            raise bad from None
        if relative:
            value /= 100.0
    else:
        raise bad
    if not math.isfinite(value) or value <= 0:
        raise bad
    if not math.isfinite(3.0 * value):
        raise UncertaintyError(f"{where} {checks.quote(given)}: 3 sigma is not a finite number; expected a SIGMA far below 1e300")
    return SigmaSpec(name, value, relative, dist, given)


def sigmas_from_table(table: Any, where: str = "[uncertainty]") -> tuple[SigmaSpec, ...]:
    """The specs of a scene file's ``[uncertainty]`` table (values: numbers or strings as for :func:`parse_sigma`)."""
    if not isinstance(table, dict):
        raise UncertaintyError(f"{where}: expected a table of NAME = SIGMA, got {checks.quote(table)}")
    return tuple(_spec(str(k), v, where, f"{k}={v}") for k, v in table.items())


def load_sigmas(path: str | Path) -> tuple[SigmaSpec, ...]:
    """The ``[uncertainty]`` table of a scene file (empty when it has none)."""
    data = inputs.load_toml(path, "scene file", UncertaintyError)
    return sigmas_from_table(data.get("uncertainty", {}), f"scene file {str(path)!r} [uncertainty]")


def resolve_sigmas(scene: Scene, specs: Sequence[SigmaSpec], section: dict | None = None) -> tuple[Sigma, ...]:
    """Absolute sigmas for ``scene``; a later spec of the same name replaces an earlier one.

    With ``section`` (both stiffnesses of the 3-D section, N mm^2) the parameters are the 3-D
    scene's (:func:`esba.analysis.sensitivity3d.parameter_names3d`: also ``Beta<k>``, ``EI_side``, ``GJ``).

    Raises
    ------
    UncertaintyError
        for a name that is not a parameter of the scene, or a relative sigma of a parameter at 0.
    """
    if not isinstance(scene, Scene):
        raise UncertaintyError(f"scene={checks.quote(scene)}: expected an esba.model.scene.Scene")
    if isinstance(specs, SigmaSpec):
        specs = [specs]
    if isinstance(specs, (str, bytes)) or not isinstance(specs, (list, tuple)):
        raise UncertaintyError(f"specs={checks.quote(specs)}: expected a list of SigmaSpec (from parse_sigma)")
    by_name: dict[str, SigmaSpec] = {}
    for s in specs:
        if not isinstance(s, SigmaSpec):
            raise UncertaintyError(f"sigmas: expected SigmaSpec, got {checks.quote(s)}")
        by_name[s.name] = s
    _check_names(scene, list(by_name), section is not None)
    params = {p.name: p for p in (scene_parameters(scene) if section is None else scene_parameters3d(scene, section))}
    out = []
    for name in params:
        if name not in by_name:
            continue
        s, p = by_name[name], params[name]
        width = s.value * abs(p.value) if s.relative else s.value
        if width <= 0:
            raise UncertaintyError(f"sigma {checks.quote(s.given)}: {name} is 0 in this scene, so a relative sigma is 0; give it in {p.unit}")
        sigma = width / math.sqrt(3.0) if s.distribution == "uniform" else width
        reach = width if s.distribution == "uniform" else 3.0 * sigma
        if not (math.isfinite(reach) and math.isfinite(p.value + reach) and math.isfinite(p.value - reach)):
            raise UncertaintyError(f"sigma {checks.quote(s.given)}: {name} +- 3 sigma is not a finite number of {p.unit}; expected a sigma far below 1e300")
        out.append(Sigma(name, p.unit, p.value, sigma, s.distribution, width if s.distribution == "uniform" else None, s.given))
    return tuple(out)


def _check_names(scene: Scene, names: list[str], three_d: bool) -> None:
    try:
        (check_names3d if three_d else check_names)(scene, names, "sigma of")
    except SensitivityError as exc:
        spatial = not three_d and any(n in ("EI_side", "GJ") or (n.startswith("Beta") and n[4:].isdigit()) for n in names)
        raise UncertaintyError(str(exc) + (" (EI_side, GJ and Beta<k> are the 3-D model's: esba solve --3d)" if spatial else "")) from None


def _checked_sigmas(scene: Scene | None, sigmas: Sequence[Sigma], three_d: bool = False) -> tuple[Sigma, ...]:
    """``sigmas`` as a tuple if they are resolved sigmas of parameters of ``scene`` (its 3-D parameters with ``three_d``)."""
    if isinstance(sigmas, (str, bytes)) or not isinstance(sigmas, (list, tuple)):
        raise UncertaintyError(f"sigmas={checks.quote(sigmas)}: expected a list of Sigma (from resolve_sigmas)")
    sigmas = tuple(sigmas)
    if not sigmas:
        raise UncertaintyError("sigmas: give at least one uncertain parameter (e.g. --sigma E=0.05)")
    for s in sigmas:
        if not isinstance(s, Sigma):
            raise UncertaintyError(f"sigmas: expected Sigma (from resolve_sigmas), got {checks.quote(s)}")
    if scene is not None:
        _check_names(scene, [s.name for s in sigmas], three_d)
    return sigmas


def domain(scene: Scene, name: str) -> tuple[float, float, bool, bool, str]:
    """The values parameter ``name`` may take in ``scene``, the others held: (low, high,
    low included, high included, the rule in words). The rules are the scene's own
    (:class:`esba.model.scene.Actuator`, :class:`esba.model.scene.Payload`, :class:`esba.model.scene.Scene`).

    >>> from esba.model.scene import MAIN_JOB
    >>> domain(MAIN_JOB, "r2")[4]
    '0 < r2 < r1 - d = 4 mm'
    >>> domain(MAIN_JOB, "s1")[4]
    '0 < s1 <= 1 (1 = tip)'
    """
    a = scene.actuator
    kind = name.rstrip("0123456789") if name[:1] in "FOsB" else name
    inf = math.inf
    if kind == "Beta":
        return -90.0, 90.0, True, True, "-90 <= Beta <= 90 deg (out of the bending plane)"
    if kind in ("EI_side", "GJ"):
        return 0.0, inf, False, False, f"{name} > 0 N*mm^2"
    if kind in ("L", "E", "g", "target_angle"):
        return 0.0, inf, False, False, f"{name} > 0 {UNITS[kind]}"
    if kind == "r1":
        return a.r2 + a.d, inf, False, False, f"r1 > r2 + d = {a.r2 + a.d:g} mm"
    if kind == "r2":
        return 0.0, a.r1 - a.d, False, False, f"0 < r2 < r1 - d = {a.r1 - a.d:g} mm"
    if kind == "d":
        return 0.0, a.r1 - a.r2, True, False, f"0 <= d < r1 - r2 = {a.r1 - a.r2:g} mm"
    if kind == "rho":
        return 0.0, 90.0, True, False, "0 <= rho < 90 deg"
    if kind in ("M", "P", "F"):
        return 0.0, inf, True, False, f"{name} >= 0 {UNITS[kind]}"
    if kind == "s":
        return 0.0, 1.0, False, True, f"0 < {name} <= 1 (1 = tip)"
    return -inf, inf, False, False, f"any {name}"


def outside_domain(scene: Scene, sigmas: Sequence[Sigma], three_d: bool = False) -> list[str]:
    """One line for each sigma whose +-3 sigma range (a tolerance: its +-t) leaves the parameter's
    :func:`domain`: part of the Monte Carlo's samples fall outside the scene's rules (they are
    counted and left out), and the first-order answer stands on values the model does not take.

    >>> from esba.model.scene import MAIN_JOB
    >>> outside_domain(MAIN_JOB, resolve_sigmas(MAIN_JOB, [parse_sigma("E=10%")]))
    []
    >>> outside_domain(MAIN_JOB, resolve_sigmas(MAIN_JOB, [parse_sigma("E=1000%")]))[0]  # doctest: +ELLIPSIS
    "sigma 'E=1000%': E = 0.54 +- 3 sigma spans -15.7 to 16.7 MPa, beyond the domain E > 0 MPa; ..."
    """
    out = []
    for s in _checked_sigmas(scene, sigmas, three_d):
        low, high, low_in, high_in, rule = domain(scene, s.name)
        reach = s.half_width if s.half_width is not None else 3.0 * s.sigma
        lo, hi = s.nominal - reach, s.nominal + reach
        below = lo < low or (lo == low and not low_in)
        above = hi > high or (hi == high and not high_in)
        if below or above:
            unit = "" if s.unit == "1" else f" {s.unit}"
            spread = "+- t" if s.half_width is not None else "+- 3 sigma"
            out.append(
                f"sigma {checks.quote(s.given)}: {s.name} = {s.nominal:.4g} {spread} spans {lo:.3g} to {hi:.3g}{unit}, "
                f"beyond the domain {rule}; the Monte Carlo leaves out the samples outside it, first order extrapolates"
            )
    return out
