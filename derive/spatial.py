"""Spatial kinematics: the POE map of Eq. (1)-(2) on SE(3), each joint carrying three rotations.

Eq. (2) writes segment i of the planar actuator as ``exp(xi_i theta_i)`` with the twist
``xi_i theta_i = [l_i theta_i, 0, 0, 0, 0, theta_i] = [L/n, 0, 0, 0, 0, theta_i]``: a rotation
about z through (0, l_i, 0), i.e. a circular arc of length L/n. In space the segment keeps its
length and gains a sideways bend ``psi_i`` (about y) and a twist ``tau_i`` (about the tangent x):

    g_i = exp( hat(Xi_i) ),    Xi_i = [L/n, 0, 0, tau_i, psi_i, theta_i],
    g_st(q) = g_1 g_2 ... g_n                                              (Eq. 2 on SE(3))

so every segment is a piece of a helix of constant curvature (psi_i, theta_i) n/L and twist
tau_i n/L: the piecewise-constant-strain Cosserat rod, inextensible and unshearable like the
paper's layer. With psi = tau = 0 the twist is the paper's, and the map is the planar one exactly
(``test_spatial`` checks it symbolically).

The exponential in closed form (Murray-Li-Sastry Prop. 2.9, the SO(3) left Jacobian V):

    exp(hat(Xi)) = [[A, V (L/n) e_x], [0, 1]],   A = I + f1 W + f2 W^2,   V = I + f2 W + f3 W^2,
    W = hat(w), w = (tau, psi, theta), s = |w|^2,
    f1 = sin(r)/r, f2 = (1 - cos r)/r^2, f3 = (r - sin r)/r^3,  r = sqrt(s).

The point at fraction sigma of a segment is ``exp(sigma hat(Xi))``. Derivatives follow from the
left Jacobian: ``dA/dq_a = hat(omega_a) A`` with ``omega_a = sigma V(sigma w) e_(a)`` (the
spatial angular velocity of the segment per unit rate of q_a, in the segment's start frame). The
f's are functions of s only; they are ``Piecewise`` (a series for s < 1, the closed form beyond)
so that value, gradient and Hessian are exact at w = 0, where every segment is straight.
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from . import symbols as S
from .kinematics import skew

#: Where the series branch of f1, f2, f3 hands over to the closed form (s = r^2 < 1).
SERIES_SWITCH = sp.Integer(1)
#: Terms kept in the series; the truncation error at s = 1 is below 1/(2*12+5)! ~ 1e-31.
SERIES_TERMS = 12

#: The joint angles of the 3-D template: in-plane bend, sideways bend, twist.
th, ps, ta = sp.symbols("t_theta t_psi t_tau", real=True)
#: The fraction of the segment and the segment length L/n.
sg = sp.Symbol("sigma", real=True)
h = sp.Symbol("h", positive=True)

# the smooth functions of s, as symbols for the templates (value, first and second derivative)
F = {name: sp.Symbol(name) for name in ("F1", "F2", "F2p", "F2pp", "F3", "F3p", "F3pp")}
_NEXT = {F["F2"]: F["F2p"], F["F2p"]: F["F2pp"], F["F3"]: F["F3p"], F["F3p"]: F["F3pp"]}


def coordinates() -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """(theta, psi, tau): the three rotations of a joint, in the model's order."""
    return th, ps, ta


def rotation_vector(q=(th, ps, ta)) -> sp.Matrix:
    """The joint's rotation vector (about x, y, z) = (tau, psi, theta)."""
    return sp.Matrix([q[2], q[1], q[0]])


def segment_twist3d(q, n) -> sp.Matrix:
    """Xi_i = [L/n, 0, 0, tau_i, psi_i, theta_i]: with psi = tau = 0, the paper's xi_i theta_i."""
    w = rotation_vector(q)
    return sp.Matrix([S.L / n, 0, 0, w[0], w[1], w[2]])


def _series(k0: int, s: sp.Expr, order: int = 0) -> sp.Expr:
    """The ``order``-th derivative of sum_k (-1)^k s^k / (2k + k0)!, in Horner form."""
    out = sp.Integer(0)
    for k in range(SERIES_TERMS, order - 1, -1):
        coeff = sp.Integer((-1) ** k) * sp.ff(k, order) / sp.factorial(2 * k + k0)
        out = coeff + s * out
    return out


def _closed(k0: int, s: sp.Expr) -> sp.Expr:
    r = sp.sqrt(s)
    return {1: sp.sin(r) / r, 2: (1 - sp.cos(r)) / s, 3: (r - sp.sin(r)) / (s * r)}[k0]


def smooth_f(k0: int, order: int, s: sp.Expr) -> sp.Expr:
    """The ``order``-th derivative in s of f_{k0}(s) (k0 = 1, 2, 3) as a Piecewise exact at 0.

    The closed form's argument is s + 1 inside the series branch, so that its (unused) value and
    derivatives stay finite where CasADi evaluates both branches (see :mod:`derive.smooth`).
    """
    x = sp.Symbol("x", positive=True)
    ser = _series(k0, s, order)
    guarded = s + sp.Piecewise((1, s < SERIES_SWITCH), (0, True))
    clo = sp.diff(_closed(k0, x), x, order).subs(x, guarded)
    return sp.Piecewise((ser, s < SERIES_SWITCH), (clo, True))


def f_values(s: sp.Expr) -> dict[sp.Symbol, sp.Expr]:
    """The values of the F symbols at ``s``."""
    return {
        F["F1"]: smooth_f(1, 0, s),
        F["F2"]: smooth_f(2, 0, s), F["F2p"]: smooth_f(2, 1, s), F["F2pp"]: smooth_f(2, 2, s),
        F["F3"]: smooth_f(3, 0, s), F["F3p"]: smooth_f(3, 1, s), F["F3pp"]: smooth_f(3, 2, s),
    }


def _total_diff(e: sp.Expr, var: sp.Symbol, ds: sp.Expr) -> sp.Expr:
    """d e / d var with the F symbols functions of s(var): dF/dvar = F' ds/dvar."""
    out = sp.diff(e, var)
    for f, fp in _NEXT.items():
        c = sp.diff(e, f)
        if c != 0:
            out += c * fp * ds
    for f in (F["F2pp"], F["F3pp"]):
        assert sp.diff(e, f) == 0, "third derivatives of f are not provided"
    return out


def _mat_diff(m: sp.Matrix, var, ds) -> sp.Matrix:
    return m.applyfunc(lambda e: sp.expand(_total_diff(e, var, ds)))


@lru_cache(maxsize=None)
def segment_template() -> dict[str, object]:
    """Everything the chain assembly needs of ``exp(sigma hat(Xi))``, in terms of th, ps, ta,
    sigma, h and the F symbols (evaluated at s = sigma^2 |w|^2).

    Keys: ``s`` (the argument of the f's), ``A`` (3x3 rotation), ``v`` (translation), ``Om``
    (list of the three omega_a, a over (theta, psi, tau)), ``dv`` (dv/dq_a), ``ddv`` and ``dOm``
    (dicts over a <= b of d2v/dq_a dq_b and d omega_a / dq_b).
    """
    q = (th, ps, ta)
    w = rotation_vector(q)
    W = skew(w)
    s = sg**2 * (w.T * w)[0]
    A = sp.eye(3) + sg * F["F1"] * W + sg**2 * F["F2"] * W * W
    V = sp.eye(3) + sg * F["F2"] * W + sg**2 * F["F3"] * W * W
    ex = sp.Matrix([1, 0, 0])
    v = (sg * h * V * ex).applyfunc(sp.expand)
    # omega_a = sigma V e_(a), e_(a) the axis of coordinate a: theta -> z, psi -> y, tau -> x
    axes = [sp.Matrix([0, 0, 1]), sp.Matrix([0, 1, 0]), sp.Matrix([1, 0, 0])]
    Om = [(sg * V * e).applyfunc(sp.expand) for e in axes]
    ds = [sp.diff(s, qa) for qa in q]
    dv = [_mat_diff(v, q[a], ds[a]) for a in range(3)]
    ddv, dOm = {}, {}
    for a in range(3):
        for b in range(a, 3):
            ddv[(a, b)] = _mat_diff(dv[a], q[b], ds[b])
            dOm[(a, b)] = _mat_diff(Om[a], q[b], ds[b])
    return {"s": s, "A": A, "v": v, "Om": Om, "dv": dv, "ddv": ddv, "dOm": dOm}


def template_outputs() -> tuple[list[str], list[sp.Expr]]:
    """The template flattened: names and expressions, in a fixed order."""
    t = segment_template()
    names: list[str] = []
    exprs: list[sp.Expr] = []

    def put(name, m):
        for i, e in enumerate(m):
            names.append(f"{name}{i}")
            exprs.append(e)

    put("A", t["A"])
    put("v", t["v"])
    for a in range(3):
        put(f"Om{a}_", t["Om"][a])
        put(f"dv{a}_", t["dv"][a])
    for (a, b), m in t["ddv"].items():
        put(f"ddv{a}{b}_", m)
        put(f"dOm{a}{b}_", t["dOm"][(a, b)])
    return names, exprs


# ---------------------------------------------------------------------------------------------
# The map itself, for proofs and checks (not used by code generation)


def exp_se3(xi: sp.Matrix) -> sp.Matrix:
    """exp(hat(xi)) of a twist xi = [v; w] with |w| != 0 symbolic, in closed form (Rodrigues)."""
    from .kinematics import hat

    return (hat(xi)).exp()


def poe3d(qs: list[tuple], n: int | None = None) -> sp.Matrix:
    """g_st(q) = prod exp(hat(Xi_i)) (Eq. 2 on SE(3)) from the closed form of the template."""
    n = len(qs) if n is None else n
    t = segment_template()
    g = sp.eye(4)
    for q in qs:
        sub = {th: q[0], ps: q[1], ta: q[2], sg: 1, h: S.L / n}
        s = t["s"].xreplace(sub)
        fs = {k: v for k, v in f_values(s).items()}
        gi = sp.eye(4)
        gi[:3, :3] = t["A"].xreplace(sub).xreplace(fs)
        gi[:3, 3] = t["v"].xreplace(sub).xreplace(fs)
        g = g * gi
    return g
