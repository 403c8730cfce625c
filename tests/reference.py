"""A brute-force SymPy reference of the model, for checking the generated code by numbers.

Built the naive way on purpose: cumulative angles written out as sums, points as explicit sums of
rotated chords, and the gradient and Hessian by ``sympy.diff`` of the whole expression. It shares
only the per-term derivations (``derive.energy``) and the smooth chord with the generator, not
the chain-sum assembly (``derive.kinematics.chain_sum_derivatives``) that it checks. Feasible for
small n only (that is the point of the chain form).
"""

from __future__ import annotations

import math
from functools import lru_cache

import sympy as sp

from esba.derive import energy
from esba.derive import symbols as S
from esba.derive.effects import EffectSet
from esba.derive.kinematics import chord, fraction_in_segment


def point(thetas, s_value: float, n: int):
    """The point at fraction ``s_value`` of L, as an explicit SymPy sum (parameters numeric)."""
    x = y = sp.Integer(0)
    for i in range(n):
        phi = sum(thetas[:i], sp.Integer(0))
        sig = fraction_in_segment(sp.nsimplify(s_value), i + 1, n)
        c = chord(thetas[i], sig, n)
        x += sp.cos(phi) * c[0] - sp.sin(phi) * c[1]
        y += sp.sin(phi) * c[0] + sp.cos(phi) * c[1]
    return x, y


def energy_expr(n: int, effects: EffectSet, variant: str, values: dict) -> tuple[list, sp.Expr]:
    """U(theta) with every parameter replaced by its value in ``values``."""
    th = S.theta(n)
    sep = energy.separable(effects.names(), n, variant)
    U = sum((e.subs(S.t, th[i]) for e in sep.values() for i in range(n)), sp.Integer(0))
    for k in range(1, effects.payloads + 1):
        F, Om, s = (values[f"F{k}"], values[f"Omega{k}"], values[f"s{k}"])
        f = (F * math.cos(Om), -F * math.sin(Om))
        x, y = point(th, s, n)
        U += -(f[0] * (x - s * S.L) + f[1] * y)
    if effects.gravity:
        weight = values["M"] * values["g"] / n
        for i in range(n):
            x, _ = point(th, (i + 0.5) / n, n)
            U += -weight * (x - (i + 0.5) / n * S.L)
    subs = {S.by_name(k): v for k, v in values.items() if k in effects.parameters()}
    return th, U.subs(subs)


@lru_cache(maxsize=None)
def _functions(n: int, effects: EffectSet, variant: str, key: tuple):
    values = dict(key)
    th, U = energy_expr(n, effects, variant, values)
    grad = [sp.diff(U, t) for t in th]
    hess = [[sp.diff(grad[i], th[j]) for j in range(n)] for i in range(n)]
    mods = ["math"]  # Piecewise as a Python conditional: only the branch taken is evaluated
    return (
        sp.lambdify([th], U, modules=mods),
        sp.lambdify([th], grad, modules=mods),
        sp.lambdify([th], hess, modules=mods),
    )


def evaluate(n: int, effects: EffectSet, variant: str, values: dict, theta):
    """(U, gradient, Hessian) of the reference at ``theta`` (plain floats)."""
    key = tuple(sorted((k, float(v)) for k, v in values.items()))
    fU, fg, fH = _functions(n, effects, variant, key)
    th = [float(t) for t in theta]
    return fU(th), fg(th), fH(th)
