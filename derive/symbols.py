"""Every symbol of the model, named as in the paper, with its unit.

Units: mm, N, MPa (= N/mm^2), so energies are in N*mm; angles in radians.

=========  =====  ==========================================================
symbol     unit   meaning
=========  =====  ==========================================================
L          mm     length of the inextensible layer (actuator length)
r1         mm     external radius
r2         mm     chamber radius
d          mm     eccentric distance of the chamber centre from the axis
rho        rad    fibre winding angle
E          MPa    Young's modulus of the rubber
P          MPa    air pressure (gauge)
F_k        N      magnitude of payload k
Omega_k    rad    direction of payload k from the vertical (Eq. 14)
s_k        1      point of application of payload k, fraction of L (1 = tip)
M          kg     mass of the actuator
g          m/s^2  gravitational acceleration (M*g in N)
theta_i    rad    bending angle of segment i (joint angle of the virtual robot)
l_i        mm     bending radius of segment i, l_i = L/(n theta_i) (Eq. 1)
=========  =====  ==========================================================
"""

from __future__ import annotations

import sympy as sp

L, r1, r2, d = sp.symbols("L r1 r2 d", positive=True)
rho = sp.Symbol("rho", real=True)
E, P = sp.symbols("E P", real=True)
M, g = sp.symbols("M g", real=True)
#: A generic segment angle, for the per-segment templates.
t = sp.Symbol("t", real=True)
#: A generic fraction of a segment (0..1), for points inside a segment.
sigma = sp.Symbol("sigma", real=True)
#: Integration variables of Eq. (6)-(8) and (11)-(13).
alpha, beta, omega = sp.symbols("alpha beta omega", real=True)


def theta(n: int) -> list[sp.Symbol]:
    """The joint angles ``theta_1 .. theta_n``."""
    return [sp.Symbol(f"theta_{i}", real=True) for i in range(1, n + 1)]


def payload(k: int) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Magnitude, direction and point of payload ``k`` (1-based)."""
    return (
        sp.Symbol(f"F{k}", real=True),
        sp.Symbol(f"Omega{k}", real=True),
        sp.Symbol(f"s{k}", real=True),
    )


def by_name(name: str) -> sp.Symbol:
    """The parameter symbol called ``name`` (as in :meth:`EffectSet.parameters`)."""
    fixed = {"L": L, "r1": r1, "r2": r2, "d": d, "rho": rho, "E": E, "P": P, "M": M, "g": g}
    if name in fixed:
        return fixed[name]
    for prefix, idx in (("Omega", 1), ("F", 0), ("s", 2)):
        if name.startswith(prefix) and name[len(prefix):].isdigit():
            return payload(int(name[len(prefix):]))[idx]
    raise KeyError(name)
