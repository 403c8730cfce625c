"""The spatial model as a straight-line program: energy, gradient and Hessian for any n.

Unknowns ``q = [theta_1..theta_n, psi_1..psi_n, tau_1..tau_n]`` (3n). As in :mod:`derive.program`,
nothing is expanded: every cumulative quantity is its own symbol and the derivatives follow the
screw-theory Jacobian of the chain, so each entry is O(1) and the program grows as O(n)
assignments plus O(n^2) Hessian references.

The chain. With R_j, p_j the pose at the start of segment j (R_1 = I, p_1 = 0) and the segment's
template (A_j, v_j) = exp(hat(Xi_j)) (:mod:`derive.spatial`),

    R_{j+1} = R_j A_j,   p_{j+1} = p_j + R_j v_j.

A point Q beyond the start of segment j moves, per unit rate of coordinate a of joint j, by

    D_{j,a} = R_j dv_a + Omega_{j,a} x (Q - P'_j),        Omega_{j,a} = R_j omega_a,

with P'_j = p_j + R_j v_j(sigma_j) the end of the part of segment j before Q (sigma_j the
fraction of segment j that lies before Q). Since Omega_{j,a} depends on joints 1..j only,

    d2Q / dq_{j,a} dq_{k,b} = Omega_{j,a} x D_{k,b}                    (j < k)
    d2Q / dq_{j,a} dq_{j,b} = R_j (ddv_ab + M_ab R_j^T (Q - P'_j)),
    M_ab r = dOmega_ab x r + omega_a x (omega_b x r)                    (A_ab A^T applied to r)

so a potential w . Q adds ``w . D`` to the gradient, the last line to the diagonal blocks and
``Omega_{j,a} . (D_{k,b} x w)`` off the diagonal: the loads are summed into X_{k,b} = sum D x w
first, then each off-diagonal entry is one 3-term dot product.

The in-plane terms (air, axial, radial, fibres; or the rod's) are the planar summands of
:mod:`derive.energy` in theta_i, verbatim; the sideways bend and twist add 1/2 EI_side (n/L) psi_i^2
and 1/2 GJ (n/L) tau_i^2 per segment.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from . import energy
from . import symbols as S
from .effects import check_segments, check_variant
from .effects3d import Effects3D
from .kinematics import fraction_in_segment
from .program import FunctionSpec, _Builder, _column
from . import spatial as X

#: The parameters new in the spatial family, as symbols.
EI_side, GJ, EI, kappa0 = sp.symbols("EI_side GJ EI kappa0", real=True)
gx, gy, gz = sp.symbols("gx gy gz", real=True)


def param_symbol(name: str) -> sp.Symbol:
    """The symbol of a parameter named as in :meth:`Effects3D.parameters`."""
    fixed = {"EI_side": EI_side, "GJ": GJ, "EI": EI, "kappa0": kappa0, "gx": gx, "gy": gy, "gz": gz}
    if name in fixed:
        return fixed[name]
    try:
        return S.by_name(name)
    except KeyError:
        return sp.Symbol(name, real=True)


def payload_direction(F, Omega, Beta) -> tuple:
    """f = F (cos Beta cos Omega, -cos Beta sin Omega, sin Beta): Beta = 0 is Eq. (14)'s planar force."""
    return (F * sp.cos(Beta) * sp.cos(Omega), -F * sp.cos(Beta) * sp.sin(Omega), F * sp.sin(Beta))


@dataclass
class Program3D:
    n: int
    effects: Effects3D
    variant: str
    inputs: dict[str, list[sp.Symbol]]
    assignments: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    functions: dict[str, FunctionSpec] = field(default_factory=dict)


Vec = tuple


def _add(*vs: Vec) -> Vec:
    return tuple(sp.Add(*(v[i] for v in vs)) for i in range(3))


def _scale(c, v: Vec) -> Vec:
    return tuple(c * x for x in v)


def _dot(a: Vec, b: Vec) -> sp.Expr:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _matvec(R, v: Vec) -> Vec:
    return tuple(R[i][0] * v[0] + R[i][1] * v[1] + R[i][2] * v[2] for i in range(3))


def _matTvec(R, v: Vec) -> Vec:
    return tuple(R[0][i] * v[0] + R[1][i] * v[1] + R[2][i] * v[2] for i in range(3))


PAIRS = [(a, b) for a in range(3) for b in range(a, 3)]


class _Segments:
    """The per-segment template (:func:`derive.spatial.template_outputs`) instantiated in a builder."""

    #: The argument of the f's in their own template.
    S_ARG = sp.Symbol("_s", nonnegative=True)

    def __init__(self, b: _Builder) -> None:
        self.b = b
        names, exprs = X.template_outputs()
        fdefs = X.f_values(self.S_ARG)
        # the f's of s (one template), and the kinematic template in terms of them
        b.template("f3d", [fdefs[k] for k in X.F.values()])
        b.template("seg3d", exprs)
        self.names = names

    def instance(self, prefix: str, q: tuple, sigma, h) -> dict:
        b = self.b
        mapping = {X.th: q[0], X.ps: q[1], X.ta: q[2], X.sg: sigma, X.h: h}
        s_val = b.assign(f"{prefix}_s", X.segment_template()["s"].xreplace(mapping))
        fvals = b.instantiate("f3d", f"{prefix}_f", {self.S_ARG: s_val})
        fmap = dict(zip(X.F.values(), (b.assign(f"{prefix}_{k}", v) for k, v in zip(X.F, fvals))))
        outs = b.instantiate("seg3d", prefix, {**mapping, **fmap})
        vals = dict(zip(self.names, outs))
        t: dict = {}
        t["A"] = [[b.assign(f"{prefix}_A{3 * i + k}", vals[f"A{3 * i + k}"]) for k in range(3)] for i in range(3)]
        vec = lambda key: tuple(b.assign(f"{prefix}_{key}{i}", vals[f"{key}{i}"]) for i in range(3))  # noqa: E731
        t["v"] = vec("v")
        t["Om"] = [vec(f"Om{a}_") for a in range(3)]
        t["dv"] = [vec(f"dv{a}_") for a in range(3)]
        t["ddv"] = {(a, c): vec(f"ddv{a}{c}_") for a, c in PAIRS}
        t["dOm"] = {(a, c): vec(f"dOm{a}{c}_") for a, c in PAIRS}
        return t


def _diag_block(wl: Vec, rl: Vec, t: dict, weight_ddv=None) -> dict:
    """w . d2Q/dq_a dq_b within one segment, a <= b: wl . ddv_ab + wl . M_ab rl (local frame)."""
    out = {}
    for a, c in PAIRS:
        ddv = t["ddv"][(a, c)] if weight_ddv is None else weight_ddv[(a, c)]
        m = _add(_cross(t["dOm"][(a, c)], rl), _cross(t["Om"][a], _cross(t["Om"][c], rl)))
        out[(a, c)] = _dot(wl, ddv) + _dot(wl, m)
    return out


def build3d(n: int, effects: Effects3D, variant: str = "paper") -> Program3D:
    """Build the straight-line program of the n-segment spatial model."""
    n = check_segments(n)
    check_variant(variant)
    b = _Builder()
    q = [sp.Symbol(f"q_{i}", real=True) for i in range(3 * n)]
    joint = [(q[j], q[n + j], q[2 * n + j]) for j in range(n)]
    params = {name: [param_symbol(name)] for name in effects.parameters()}
    inputs = {"q": q, **params}
    h = b.assign("h", S.L / n)
    segs = _Segments(b)

    # --- the chain: full segments, poses at the start of each segment
    full = [segs.instance(f"g{j + 1}", joint[j], sp.Integer(1), h) for j in range(n)]
    one, zero = sp.Integer(1), sp.Integer(0)
    R = [[[one, zero, zero], [zero, one, zero], [zero, zero, one]]]
    p: list[Vec] = [(zero, zero, zero)]
    for j in range(n):
        Rj, A = R[j], full[j]["A"]
        p.append(tuple(b.assign(f"p{j + 2}_{i}", p[j][i] + _matvec(Rj, full[j]["v"])[i]) for i in range(3)))
        R.append([[b.assign(f"R{j + 2}_{i}{k}", sum(Rj[i][m] * A[m][k] for m in range(3))) for k in range(3)] for i in range(3)])
    WOm = [[tuple(b.assign(f"WOm{j + 1}_{a}{i}", _matvec(R[j], full[j]["Om"][a])[i]) for i in range(3)) for a in range(3)] for j in range(n)]

    N3 = 3 * n
    idx = lambda a, j: a * n + j  # noqa: E731
    grad = [sp.Integer(0)] * N3
    diag = [{pair: sp.Integer(0) for pair in PAIRS} for _ in range(n)]
    Xacc: list[list[Vec]] = [[(zero, zero, zero)] * 3 for _ in range(n)]  # sum over loads of D x w

    # --- the in-plane terms (the paper's summands in theta_i, verbatim), sideways bend, twist
    sep = energy.separable(tuple(e for e in effects.in_plane() if e != "rod"), n, variant) if any(
        e != "rod" for e in effects.in_plane()) else {}
    if effects.rod:
        sep["rod"] = sp.Rational(1, 2) * EI * n / S.L * (S.t - kappa0 * S.L / n) ** 2
    u_side = sp.Rational(1, 2) * EI_side * n / S.L * X.ps**2
    u_twist = sp.Rational(1, 2) * GJ * n / S.L * X.ta**2
    names = list(sep)
    u = sum(sep.values(), sp.Integer(0))
    b.template("seg", [*sep.values(), sp.diff(u, S.t), sp.diff(u, S.t, 2)])
    sums = {name: sp.Integer(0) for name in [*names, "side", "twist"]}
    for j in range(n):
        vals = b.instantiate("seg", f"u{j + 1}", {S.t: joint[j][0]})
        for name, val in zip(names, vals):
            sums[name] += val
        grad[idx(0, j)] += vals[-2]
        diag[j][(0, 0)] += vals[-1]
        sums["side"] += u_side.xreplace({X.ps: joint[j][1]})
        sums["twist"] += u_twist.xreplace({X.ta: joint[j][2]})
        grad[idx(1, j)] += sp.diff(u_side, X.ps).xreplace({X.ps: joint[j][1]})
        grad[idx(2, j)] += sp.diff(u_twist, X.ta).xreplace({X.ta: joint[j][2]})
        diag[j][(1, 1)] += sp.diff(u_side, X.ps, 2)
        diag[j][(2, 2)] += sp.diff(u_twist, X.ta, 2)
    terms_out = {name: b.assign(f"U_{name}", sums[name]) for name in sums}

    # --- payloads: w . Q(s) with w = -f, Q(s) the chain with fractions sigma_j of each segment
    for k in range(1, effects.payloads + 1):
        Fk, Om_k, s_k = S.payload(k)
        f = payload_direction(Fk, Om_k, param_symbol(f"Beta{k}"))
        w = tuple(b.assign(f"w{k}_{i}", -f[i]) for i in range(3))
        sig = [b.assign(f"sig{k}_{j + 1}", fraction_in_segment(s_k, j + 1, n)) for j in range(n)]
        part = [segs.instance(f"pl{k}s{j + 1}", joint[j], sig[j], h) for j in range(n)]
        rot = [tuple(b.assign(f"pl{k}r{j + 1}_{i}", _matvec(R[j], part[j]["v"])[i]) for i in range(3)) for j in range(n)]
        tail: list[Vec] = [(zero, zero, zero)] * n  # Q - P'_j = sum_{i > j} R_i v_i(sigma_i)
        acc: Vec = (zero, zero, zero)
        for j in range(n - 1, -1, -1):
            tail[j] = acc
            acc = tuple(b.assign(f"pl{k}t{j + 1}_{i}", acc[i] + rot[j][i]) for i in range(3))
        Q = acc
        wl_all = [tuple(b.assign(f"pl{k}wl{j + 1}_{i}", _matTvec(R[j], w)[i]) for i in range(3)) for j in range(n)]
        for j in range(n):
            t = part[j]
            rl = tuple(b.assign(f"pl{k}rl{j + 1}_{i}", _matTvec(R[j], tail[j])[i]) for i in range(3))
            wl = wl_all[j]
            for a in range(3):
                # D = R_j (dv_a + omega_a x rl): in the local frame, then rotated
                Dl = _add(t["dv"][a], _cross(t["Om"][a], rl))
                D = tuple(b.assign(f"pl{k}D{j + 1}_{a}{i}", _matvec(R[j], Dl)[i]) for i in range(3))
                grad[idx(a, j)] += _dot(wl, Dl)
                Xacc[j][a] = _add(Xacc[j][a], _cross(D, w))
            for pair, val in _diag_block(wl, rl, t).items():
                diag[j][pair] += val
        terms_out[f"payload{k}"] = b.assign(f"U_payload{k}", _dot(w, Q) + f[0] * s_k * S.L)

    # --- moments: -m . sum_j sigma_j (tau_j, psi_j, theta_j), m in body components
    for k in range(1, effects.moments + 1):
        m = tuple(param_symbol(f"{c}{k}") for c in ("mx", "my", "mz"))
        sm = param_symbol(f"sm{k}")
        sig = [b.assign(f"sm{k}_{j + 1}", fraction_in_segment(sm, j + 1, n)) for j in range(n)]
        pot = sp.Integer(0)
        for j in range(n):
            for a, comp in ((0, 2), (1, 1), (2, 0)):  # theta about z, psi about y, tau about x
                pot += -m[comp] * sig[j] * joint[j][a]
                grad[idx(a, j)] += -m[comp] * sig[j]
        terms_out[f"moment{k}"] = b.assign(f"U_moment{k}", pot)

    # --- couples: dead forces +f at P(s) + R(s) e and -f at P(s), f = (m x e)/|e|^2, on a rigid arm e
    #     fixed to the section at s: the potential w . R(s) e (w = -f) is conservative at any rotation,
    #     and its moment at the straight state is e x f = m (m perpendicular to e). Only the arm's
    #     offset R(s) e moves relative to P(s): it moves rigidly with the frame at s, so each joint
    #     adds Omega_{j,a} x (R(s) e) alone (the d v terms of the two forces cancel).
    for k in range(1, effects.couples + 1):
        m = tuple(param_symbol(f"{c}{k}") for c in ("cx", "cy", "cz"))
        e = tuple(param_symbol(f"{c}{k}") for c in ("ax", "ay", "az"))
        e2 = _dot(e, e)
        w = tuple(b.assign(f"cw{k}_{i}", -_cross(m, e)[i] / e2) for i in range(3))
        sig = [b.assign(f"sc{k}_{j + 1}", fraction_in_segment(param_symbol(f"sc{k}"), j + 1, n)) for j in range(n)]
        part = [segs.instance(f"cp{k}s{j + 1}", joint[j], sig[j], h) for j in range(n)]
        Rs = [[one, zero, zero], [zero, one, zero], [zero, zero, one]]
        for j in range(n):  # R(s): the product of the parts of every segment before s
            A = part[j]["A"]
            Rs = [[b.assign(f"cR{k}_{j + 1}_{i}{c}", sum(Rs[i][mm] * A[mm][c] for mm in range(3))) for c in range(3)] for i in range(3)]
        off = tuple(b.assign(f"coff{k}_{i}", _matvec(Rs, e)[i]) for i in range(3))
        for j in range(n):
            t = part[j]
            ol = tuple(b.assign(f"c{k}ol{j + 1}_{i}", _matTvec(R[j], off)[i]) for i in range(3))
            wl = tuple(b.assign(f"c{k}wl{j + 1}_{i}", _matTvec(R[j], w)[i]) for i in range(3))
            for a in range(3):
                Dl = _cross(t["Om"][a], ol)
                D = tuple(b.assign(f"c{k}D{j + 1}_{a}{i}", _matvec(R[j], Dl)[i]) for i in range(3))
                grad[idx(a, j)] += _dot(wl, Dl)
                Xacc[j][a] = _add(Xacc[j][a], _cross(D, w))
            no_ddv = {pair: (zero, zero, zero) for pair in PAIRS}
            for pair, val in _diag_block(wl, ol, t, no_ddv).items():
                diag[j][pair] += val
        terms_out[f"couple{k}"] = b.assign(f"U_couple{k}", _dot(w, off) - _dot(w, e))

    # --- gravity: the weight M g / n of every segment at its mid-point, g = (gx, gy, gz)
    if effects.gravity:
        w = tuple(b.assign(f"wg_{i}", -S.M * gi / n) for i, gi in enumerate((gx, gy, gz)))
        half = [segs.instance(f"hf{j + 1}", joint[j], sp.Rational(1, 2), h) for j in range(n)]
        mids = [tuple(b.assign(f"mid{j + 1}_{i}", p[j][i] + _matvec(R[j], half[j]["v"])[i]) for i in range(3)) for j in range(n)]
        G: list[Vec] = [(zero, zero, zero)] * n  # sum of the mid-points beyond segment j
        acc = (zero, zero, zero)
        for j in range(n - 1, -1, -1):
            G[j] = acc
            acc = tuple(b.assign(f"G{j + 1}_{i}", acc[i] + mids[j][i]) for i in range(3))
        total = acc
        for j in range(n):
            c = n - 1 - j  # mid-points wholly beyond segment j
            t, th_ = full[j], half[j]
            wl = tuple(b.assign(f"gwl{j + 1}_{i}", _matTvec(R[j], w)[i]) for i in range(3))
            rel = tuple(G[j][i] - c * p[j + 1][i] for i in range(3))
            rl = tuple(b.assign(f"grl{j + 1}_{i}", _matTvec(R[j], rel)[i]) for i in range(3))
            for a in range(3):
                Dl = _add(_scale(c, t["dv"][a]), th_["dv"][a], _cross(t["Om"][a], rl))
                D = tuple(b.assign(f"gD{j + 1}_{a}{i}", _matvec(R[j], Dl)[i]) for i in range(3))
                grad[idx(a, j)] += _dot(wl, Dl)
                Xacc[j][a] = _add(Xacc[j][a], _cross(D, w))
            weighted = {pair: _add(_scale(c, t["ddv"][pair]), th_["ddv"][pair]) for pair in PAIRS}
            for pair, val in _diag_block(wl, rl, t, weighted).items():
                diag[j][pair] += val
        rest = S.M * (gx * S.L / 2)  # the straight actuator's mid-points: sum_i (i - 1/2) L/n along x
        terms_out["gravity"] = b.assign("U_gravity", _dot(w, total) + rest)

    U = b.assign("U", sum(terms_out.values(), sp.Integer(0)))
    g_syms = [b.assign(f"grad{i + 1}", grad[i]) for i in range(N3)]
    Xs = [[tuple(b.assign(f"X{j + 1}_{a}{i}", Xacc[j][a][i]) for i in range(3)) for a in range(3)] for j in range(n)]
    H = [[sp.Integer(0)] * N3 for _ in range(N3)]
    for j in range(n):
        for a, c in PAIRS:
            e = b.assign(f"hd{j + 1}_{a}{c}", diag[j][(a, c)])
            H[idx(a, j)][idx(c, j)] = H[idx(c, j)][idx(a, j)] = e
        for k in range(j + 1, n):
            for a in range(3):
                for c in range(3):
                    e = _dot(WOm[j][a], Xs[k][c])
                    H[idx(a, j)][idx(c, k)] = H[idx(c, k)][idx(a, j)] = e

    tip = _column(list(p[n]))
    rot_tip = [list(row) for row in R[n]]
    points = [[p[j][i] for j in range(n + 1)] for i in range(3)]
    pnames = ["q", *effects.parameters()]
    terms_vec = _column([terms_out[name] for name in effects.terms()])
    functions = {
        "energy": FunctionSpec(pnames, {"U": [[U]], "terms": terms_vec}, "total potential energy U (N*mm) and its terms, in the order of TERMS"),
        "gradient": FunctionSpec(pnames, {"grad": _column(g_syms)}, "dU/dq (N*mm/rad), q = [theta; psi; tau]"),
        "hessian": FunctionSpec(pnames, {"hess": H}, "d2U/dq2 (N*mm/rad^2), dense and symmetric"),
        "kinematics": FunctionSpec(["q", "L"], {"tip": tip, "R": rot_tip, "points": points},
                                   "tip position (mm), tip rotation (3 x 3) and the n+1 segment end points (3 x (n+1), mm)"),
    }
    return Program3D(n, effects, variant, inputs, b.assignments, functions)
