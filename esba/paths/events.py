"""Contact events on a path, located as folds are: bracketed between two traced points, then Brent's method.

Along a path in one parameter (a pressure, a prescribed displacement) the set of active contacts
changes at *events*: a point of the body **touches** an obstacle (its gap reaches 0), a contact
**lifts off** (its force reaches 0), or a contact **slides** onto a joint or the tip (a segment's
interior contact point reaches its end, where the joint's gap reaches 0 as the interior contact's
force hands over to it). Each is the zero of a scalar function of the parameter evaluated on the
continuation of the *old* active set (the gap of the point that touches, the force of the contact
that lifts off); the caller, which can solve, supplies it (:mod:`esba.statics.contact.sweeps`), and
:func:`locate_event` brackets and refines it to a relative 1e-10 in the parameter.

A contact can also be **lost** with its force still clearly positive (``contact lost``): the contact
branch ends (the contact slides off an edge and the actuator snaps), and no equilibrium in contact
follows. No function crosses zero there; :func:`bisect_event` locates it by bisection on where a
solve from the last equilibrium in contact still holds it, to the same relative 1e-10.

Examples
--------
>>> e = locate_event(lambda p: 0.12 - p, 0.1, 0.15, "touch", "tip", "half-plane #1")
>>> e.kind, round(e.parameter, 12), e.status
('touch', 0.12, 'converged')
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

from esba.solvers.roots import brentq

__all__ = ["ContactEvent", "locate_event", "bisect_event", "EVENT_KINDS"]

#: The kinds of contact event.
EVENT_KINDS = ("touch", "lift-off", "slide", "contact lost")


@dataclass(frozen=True)
class ContactEvent:
    """A located contact event: its kind, the parameter, where on the body, which obstacle, how well.

    ``status`` is ``converged`` (located by Brent or by bisection to the tolerance) or ``guess`` (the
    function did not change sign on the old active set's continuation: the bracket's midpoint is reported);
    ``bracket`` the two traced parameters around it; ``force_left`` (N) a ``contact lost``'s force at
    the last equilibrium that held the contact (None for the other kinds).
    """

    kind: str
    parameter: float
    where: str
    obstacle: str
    status: str
    bracket: tuple[float, float]
    force_left: float | None = None

    def describe(self) -> str:
        """``touch at tip``, ``lift-off at joint 3``, ``slide from inside segment 6 across joint 6 into segment 7``,
        ``contact lost at tip with 0.532 N left``."""
        if self.kind == "slide":
            return f"{self.kind} {self.where}"
        left = "" if self.force_left is None else f" with {self.force_left:.4g} N left"
        return f"{self.kind} at {self.where}{left}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "description": self.describe(), "parameter": self.parameter, "where": self.where, "obstacle": self.obstacle,
                "status": self.status, "bracket": list(self.bracket), "force_left_n": self.force_left}


def locate_event(f: Callable[[float], float], a: float, b: float, kind: str, where: str, obstacle: str, rtol: float = 1e-10) -> ContactEvent:
    """The event between parameters ``a`` and ``b`` where ``f`` (> 0 before it) crosses zero."""
    if kind not in EVENT_KINDS:
        raise ValueError(f"kind={kind!r}: allowed are {', '.join(EVENT_KINDS)}")

    def safe(p: float) -> float:
        try:
            v = float(f(p))
        except (ArithmeticError, ValueError, RuntimeError):
            return math.nan
        return v

    try:
        fa, fb = safe(a), safe(b)
        if not (math.isfinite(fa) and math.isfinite(fb)) or (fa > 0) == (fb > 0) and fa != 0 and fb != 0:
            raise ValueError("no sign change")
        p = brentq(safe, a, b, xtol=rtol * max(abs(a), abs(b), 1e-12), rtol=4 * 2.220446049250313e-16)
        status = "converged"
    except (ValueError, RuntimeError):
        p, status = 0.5 * (a + b), "guess"
    return ContactEvent(kind, float(p), where, obstacle, status, (float(a), float(b)))


def bisect_event(holds: Callable[[float], bool], a: float, b: float, kind: str, where: str, obstacle: str,
                 rtol: float = 1e-10) -> ContactEvent:
    """The event between parameters ``a`` and ``b`` where ``holds`` (True at ``a``, False at ``b``; the
    caller's solve from the last parameter where it held) stops holding, by bisection to ``rtol``.

    >>> e = bisect_event(lambda p: p < 0.12, 0.1, 0.15, "contact lost", "tip", "cylinder #1")
    >>> e.kind, round(e.parameter, 9), e.status
    ('contact lost', 0.12, 'converged')
    """
    if kind not in EVENT_KINDS:
        raise ValueError(f"kind={kind!r}: allowed are {', '.join(EVENT_KINDS)}")
    lo, hi = float(a), float(b)
    tol = rtol * max(abs(lo), abs(hi), 1e-12)
    while abs(hi - lo) > tol:
        mid = 0.5 * (lo + hi)
        if holds(mid):
            lo = mid
        else:
            hi = mid
    return ContactEvent(kind, 0.5 * (lo + hi), where, obstacle, "converged", (float(a), float(b)))
