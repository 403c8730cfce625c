"""Where a result leaves the range in which the paper's model describes the actuator.

The model is linear-elastic (Section 3.2.2: "when the strain is in the range of 0-1, the stress
almost increases linearly") and has no contact: nothing stops the actuator from bending through
itself or through its clamp. An equilibrium can be perfectly converged and stable and still be
outside that range. :func:`assess` lists each way a result is, as :class:`Finding` objects
that every result carries (``Equilibrium.validity``, a sweep's rows) and the command line prints
as warning lines:

===================  ==========================================================  ===============
check                quantity                                                    flagged when
===================  ==========================================================  ===============
``axial_strain``     outer-fibre axial strain of a segment, 2 n r1 theta_i / L     abs > 1
                     (elongation of the fibre 2 r1 from the inextensible layer,
                     Eq. 6, over the segment length L / n)
``radial_strain``    chamber-wall radial strain, Delta_r2,i / (r1 - r2) with       abs > 1
                     Delta_r2,i from Eq. (10) (the paper's epsilon, Eq. 13)
``total_bend``       total bend abs(theta_TOL), Eq. (17)                            > 360 deg
``tip_behind_base``  the tip above the clamp, x < 0 (x points down the unbent axis)  x < 0
``pressure_range``   pressure against the paper's 0-0.2 MPa (Figs. 7, 12, 13)      > 1 MPa
``payload_range``    a payload against the paper's 0-2 N (Tables 2-3, Figs. 8-11)   > 10 N
===================  ==========================================================  ===============

"Far outside" the paper's range is five times its largest value: a factor chosen to flag
extrapolation that is clearly beyond the experiments, not to police every design.

This is the one rule of the model's domain. Every tool that reports a state judges it with
:func:`assess` (or :func:`assess_angles` and :func:`assess_state`, functions of the scene and
the angles, the tip from the scene's kinematics): ``solve``, ``equilibria`` (each state's ``validity``; ``outside_domain``
counts them), paths, sweeps, ``estimate``, ``fit`` and ``design``; the exported C mirrors the
constants below (:data:`STRAIN_LIMIT`, :data:`MAX_BEND_DEG`, the tip's x < 0,
:data:`PAPER_MAX_PRESSURE` and :data:`PAPER_MAX_PAYLOAD` times :data:`FAR_FACTOR`).

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> assess(MAIN_JOB, [-0.0575, 0.125, 0.374], 0.124, [133.2, 10.2])
()
>>> five = assess(MAIN_JOB.replace(pressure=5.0), [52.17, 52.17, 52.17], 5.0, [-0.456, 0.130])  # esba solve --pressure 5
>>> [f.check for f in five]
['axial_strain', 'total_bend', 'tip_behind_base', 'pressure_range']
>>> print(five[1].message)
total bend 8967 deg is more than a full turn: the actuator would pass through itself (the model has no self-contact)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from .closed_form import pressure_for_angle
from .scene import Scene

__all__ = [
    "Finding",
    "assess",
    "assess_angles",
    "assess_state",
    "assess_arrays",
    "outer_fibre_strain",
    "chamber_wall_strain",
    "STRAIN_LIMIT",
    "MAX_BEND_DEG",
    "PAPER_MAX_PRESSURE",
    "PAPER_MAX_PAYLOAD",
    "FAR_FACTOR",
    "MESSAGE_STARTS",
    "check_of",
    "Tally",
]

#: The strain up to which the paper takes the rubber as linear-elastic (Section 3.2.2).
STRAIN_LIMIT = 1.0
#: A total bend beyond one full turn passes the actuator through itself.
MAX_BEND_DEG = 360.0
#: The largest pressure of the paper's experiments, MPa (Fig. 7b, Fig. 12, Fig. 13a).
PAPER_MAX_PRESSURE = 0.2
#: The largest payload of the paper's experiments, N (Tables 2-3, Figs. 8-11).
PAPER_MAX_PAYLOAD = 2.0
#: "Far outside" the paper's range: this many times its largest value.
FAR_FACTOR = 5.0


@dataclass(frozen=True)
class Finding:
    """One way a result lies outside the model's range.

    Attributes
    ----------
    check : str
        Which check (see the module's table).
    value : float
        The quantity found (largest magnitude over the segments for strains), in ``unit``.
    limit : float
        The bound it passes, in ``unit``.
    unit : str
        Unit of ``value`` and ``limit`` ("1" for strains).
    message : str
        One line for a person.
    """

    check: str
    value: float
    limit: float
    unit: str
    message: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {"check": self.check, "value": self.value, "limit": self.limit, "unit": self.unit, "message": self.message}


def outer_fibre_strain(n: int, L, r1, theta) -> np.ndarray:
    """Axial strain of the outer fibre (2 r1 from the inextensible layer) of each segment.

    >>> outer_fibre_strain(3, 135.0, 8.0, [0.5]).round(4).tolist()
    [0.1778]
    """
    return 2.0 * np.asarray(r1) * n * np.asarray(theta, dtype=float) / np.asarray(L)


def chamber_wall_strain(n: int, L, r1, r2, d, theta) -> np.ndarray:
    """The paper's radial strain Delta_r2 / (r1 - r2) of each segment, Delta_r2 from Eq. (10).

    Outside the model's domain (the chamber closed) the strain is -r2 / (r1 - r2).

    It stays below 1 when the chamber widens (the radius tends to sqrt(r1^3 / (r1 + d))); it
    passes -1 only when a chamber wider than half the actuator (r2 > r1 / 2) is squeezed.

    >>> chamber_wall_strain(3, 135.0, 8.0, 3.0, 4.0, [0.0, 0.5]).round(4).tolist()
    [0.0, 0.12]
    """
    theta = np.asarray(theta, dtype=float)
    num = np.maximum(L * r2**2 + n * r1**3 * theta, 0.0)
    den = L + n * (d + r1) * theta
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(den > 0, np.sqrt(num / np.where(den > 0, den, 1.0)), 0.0)
    return (radius - r2) / (r1 - r2)


def _largest(values: np.ndarray) -> tuple[float, int]:
    k = int(np.argmax(np.abs(values)))
    return float(values[k]), k


def assess_arrays(
    n: int,
    L,
    r1,
    r2,
    d,
    theta: np.ndarray,
    tip_x: np.ndarray,
    pressure: np.ndarray,
    payload: np.ndarray,
) -> list[tuple[Finding, ...]]:
    """:func:`assess` for m results at once: ``theta`` has shape (m, n); the others are length m
    (geometry may be scalars); ``payload`` is each result's largest payload magnitude, N.

    Rows whose angles are not finite (not solved) get no findings.
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    m = theta.shape[0]

    def col(v) -> np.ndarray:
        return np.broadcast_to(np.asarray(v, dtype=float), (m,))

    L, r1, r2, d = col(L), col(r1), col(r2), col(d)
    tip_x, pressure, payload = col(tip_x), col(pressure), col(payload)
    axial = outer_fibre_strain(n, L[:, None], r1[:, None], theta)
    radial = chamber_wall_strain(n, L[:, None], r1[:, None], r2[:, None], d[:, None], theta)
    out: list[tuple[Finding, ...]] = []
    for i in range(m):
        if not np.all(np.isfinite(theta[i])):
            out.append(())
            continue
        found = []
        value, k = _largest(axial[i])
        if abs(value) > STRAIN_LIMIT:
            kind = "stretched" if value > 0 else "compressed"
            found.append(Finding(
                "axial_strain", value, STRAIN_LIMIT, "1",
                f"outer-fibre axial strain {value:.3g} in segment {k + 1} ({kind} past |strain| = 1): "
                "beyond the linear-elastic range the paper's model assumes (Section 3.2.2)",
            ))
        value, k = _largest(radial[i])
        if abs(value) > STRAIN_LIMIT:
            found.append(Finding(
                "radial_strain", value, STRAIN_LIMIT, "1",
                f"chamber-wall radial strain {value:.3g} in segment {k + 1} (past |strain| = 1, Eq. 10 and 13): "
                "beyond the linear-elastic range the paper's model assumes",
            ))
        bend = math.degrees(float(np.sum(theta[i])))
        if abs(bend) > MAX_BEND_DEG:
            found.append(Finding(
                "total_bend", bend, MAX_BEND_DEG, "deg",
                f"total bend {bend:.4g} deg is more than a full turn: the actuator would pass through itself "
                "(the model has no self-contact)",
            ))
        if tip_x[i] < 0:
            found.append(Finding(
                "tip_behind_base", float(tip_x[i]), 0.0, "mm",
                f"the tip is {-tip_x[i]:.4g} mm behind the base (x < 0): the actuator would pass through its clamp "
                "(the model has no contact)",
            ))
        if pressure[i] > FAR_FACTOR * PAPER_MAX_PRESSURE:
            found.append(Finding(
                "pressure_range", float(pressure[i]), FAR_FACTOR * PAPER_MAX_PRESSURE, "MPa",
                f"pressure {pressure[i]:.4g} MPa is far outside the paper's range (0 to {PAPER_MAX_PRESSURE:g} MPa; "
                f"flagged above {FAR_FACTOR * PAPER_MAX_PRESSURE:g} MPa): the model is not validated there",
            ))
        if payload[i] > FAR_FACTOR * PAPER_MAX_PAYLOAD:
            found.append(Finding(
                "payload_range", float(payload[i]), FAR_FACTOR * PAPER_MAX_PAYLOAD, "N",
                f"payload {payload[i]:.4g} N is far outside the paper's range (0 to {PAPER_MAX_PAYLOAD:g} N; "
                f"flagged above {FAR_FACTOR * PAPER_MAX_PAYLOAD:g} N): the model is not validated there",
            ))
        out.append(tuple(found))
    return out


def assess(scene: Scene, theta: Sequence[float], pressure: float, tip: Sequence[float]) -> tuple[Finding, ...]:
    """The findings of one result: ``theta`` (rad), ``pressure`` (MPa), ``tip`` [x, y, ...] (mm).

    An empty tuple means the result is inside the range the paper's model describes.
    """
    a = scene.actuator
    payload = max((p.force for p in scene.payloads), default=0.0)
    theta = np.asarray(theta, dtype=float).reshape(1, -1)
    return assess_arrays(theta.shape[1], a.L, a.r1, a.r2, a.d, theta, float(tip[0]), float(pressure), payload)[0]


def assess_angles(scene: Scene, theta: Sequence[float], pressure: float) -> tuple[Finding, ...]:
    """:func:`assess` for angles found some other way (e.g. a design's states): the tip comes from
    the scene's model (its kinematics)."""
    theta = np.asarray(theta, dtype=float)
    return assess(scene, theta, pressure, scene.model().tip(theta, scene.actuator.L))


#: How each check's message starts, so that a finding kept as text (a study file's ``validity``
#: column, its findings joined by `` | ``) is known again by its check.
MESSAGE_STARTS = {
    "axial_strain": "outer-fibre axial strain ",
    "radial_strain": "chamber-wall radial strain ",
    "total_bend": "total bend ",
    "tip_behind_base": "the tip is ",
    "pressure_range": "pressure ",
    "payload_range": "payload ",
}


def check_of(message: str) -> str:
    """The check whose message ``message`` is (``"other"`` for none of them).

    >>> check_of("total bend 1609 deg is more than a full turn: ..."), check_of("?")
    ('total_bend', 'other')
    """
    return next((check for check, start in MESSAGE_STARTS.items() if message.startswith(start)), "other")


class Tally:
    """Points outside the model's range, counted by check with the first point's message: one
    report, whether the findings are at hand (:class:`Finding`) or read back as text from a file.

    >>> t = Tally()
    >>> t.add([Finding("total_bend", 400.0, 360.0, "deg", "total bend 400 deg is more than a full turn")])
    >>> t.add("total bend 500 deg is more than a full turn | the tip is 1 mm behind the base (x < 0)")
    >>> t.add(())
    >>> t.points, t.lines()[0]
    (2, "2 point(s) outside the model's range, e.g. total bend 400 deg is more than a full turn")
    """

    def __init__(self) -> None:
        self.points = 0
        self.counts: dict[str, int] = {}
        self.examples: dict[str, str] = {}

    def add(self, found: Sequence[Finding] | str) -> None:
        """One point's findings: :class:`Finding` objects, or their messages joined by `` | ``."""
        pairs = [(check_of(m), m) for m in found.split(" | ") if m] if isinstance(found, str) else [(f.check, f.message) for f in found]
        if not pairs:
            return
        self.points += 1
        for check in dict.fromkeys(c for c, _ in pairs):
            self.counts[check] = self.counts.get(check, 0) + 1
            self.examples.setdefault(check, next(m for c, m in pairs if c == check))

    def lines(self) -> list[str]:
        """One line per check, in the order the checks were first met."""
        return [f"{count} point(s) outside the model's range, e.g. {self.examples[check]}" for check, count in self.counts.items()]


def assess_state(scene: Scene, theta: Sequence[float]) -> tuple[Finding, ...]:
    """The rule of the model's domain as a function of the scene and the angles (rad) alone: the
    findings of :func:`assess_angles` at the scene's pressure (or its target angle's). The exported
    C mirrors this rule with the same constants.

    >>> from esba.model.scene import Scene, Payload
    >>> [f.check for f in assess_state(Scene(pressure=0.17, payloads=(Payload(2.0),)), np.radians([73.73, 80.34, 58.77]))]
    ['tip_behind_base']
    """
    pressure = scene.pressure if scene.pressure is not None else pressure_for_angle(scene)
    return assess_angles(scene, theta, pressure)
