"""The section's inputs and closed forms: the checks of r1, r2, d (one line naming the value and what
is allowed) and the exact area, centroid and second moments of the disc minus the offset chamber.

Examples
--------
>>> exact_properties(8.0, 3.0, 4.0)["y_c"]
-7.345454545454546
>>> check_geometry(8.0, 5.0, 4.0)
Traceback (most recent call last):
...
esba.model.section.geometry.SectionError: r2=5 with d=4, r1=8: the chamber must lie inside the actuator, r2 + d < r1
"""

from __future__ import annotations

import math
from typing import Any

from esba.infra import checks
from esba.infra.errors import InputError, RunError

__all__ = ["SectionError", "SeriesError", "MIN_R1", "MAX_R1", "positive", "check_geometry", "exact_properties"]

#: The external radii the section takes, mm (the second moments go with r1⁴ and stay finite doubles).
MIN_R1, MAX_R1 = 1e-6, 1e6


class SectionError(InputError):
    """A section parameter that is not allowed: the message names it, its value and what is allowed."""


class SeriesError(RunError):
    """The series solution did not converge with the terms given."""


def positive(name: str, value: Any) -> float:
    """``value`` as a float if it is a finite number > 0, else a :class:`SectionError` naming ``name``."""
    v = checks.finite(name, value, SectionError)
    if v <= 0:
        raise SectionError(f"{name}={v:g}: expected a number > 0")
    return v


def check_geometry(r1: Any, r2: Any, d: Any) -> tuple[float, float, float]:
    """(r1, r2, d) as floats if they make a section: r1 from MIN_R1 to MAX_R1, r2 > 0, d >= 0, r2 + d < r1."""
    r1, r2 = positive("r1", r1), positive("r2", r2)
    d = checks.finite("d", d, SectionError)
    if d < 0:
        raise SectionError(f"d={d:g}: expected a number >= 0")
    if not MIN_R1 <= r1 <= MAX_R1:
        raise SectionError(f"r1={r1:g}: expected a radius from {MIN_R1:g} to {MAX_R1:g} mm (the section's J goes with r1⁴)")
    if not r2 + d < r1:
        raise SectionError(f"r2={r2:g} with d={d:g}, r1={r1:g}: the chamber must lie inside the actuator, r2 + d < r1")
    if r2 < 1e-6 * r1:
        raise SectionError(f"r2={r2:g} with r1={r1:g}: a chamber smaller than 1e-6 r1; expected a chamber the mesh can resolve")
    # the thinnest wall, r1 - r2 - d, is meshed by the radial layers: below 1e-6 r1 it is no longer a section
    if r1 - r2 - d < 1e-6 * r1:
        raise SectionError(f"r2={r2:g} with d={d:g}, r1={r1:g}: the wall r1 - r2 - d is thinner than 1e-6 r1; expected a wall the mesh can resolve")
    return r1, r2, d


def exact_properties(r1: float, r2: float, d: float) -> dict[str, float]:
    """Area, centroid and second moments of the section in closed form (see the module).

    >>> p = exact_properties(8.0, 3.0, 0.0)
    >>> round(p["I_yy"] - p["I_zz"], 12), round(p["y_c"], 12)
    (0.0, -8.0)
    """
    r1, r2, d = check_geometry(r1, r2, d)
    a1, a2 = math.pi * r1**2, math.pi * r2**2
    area = a1 - a2
    ring = math.pi * (r1**4 - r2**4) / 4
    return {
        "area": area,
        "y_c": -r1 + d * a2 / area,
        "z_c": 0.0,
        "I_yy": ring,
        "I_zz": ring - a1 * a2 * d**2 / area,
        "I_yz": 0.0,
    }
