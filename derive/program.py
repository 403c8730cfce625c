"""The n-segment model as a straight-line program: energy, gradient, Hessian, kinematics.

Differentiating the expanded POE tip position does not scale (SymPy expands the cumulative
angles into flat sums: the Hessian at n = 100 does not finish in 30 min, see
``../shared/MEASUREMENTS.md``). Instead the program keeps every cumulative quantity as its own
symbol and uses the chain structure of the POE map:

* the separable terms (air, axial, radial, fibres) are sums of one function u(theta_i) per
  segment: SymPy differentiates the summand once, for a generic angle ``t``, and the program
  instantiates it per segment (diagonal Hessian);
* payloads and gravity are potentials ``w . Q`` of chain sums ``Q = sum_k R(phi_k) v_k``
  (:func:`derive.kinematics.chain_sum_derivatives`): the local vectors v_k and their two
  derivatives come from SymPy, the assembly from the screw-theory Jacobian. Off the diagonal,
  ``d2(w.Q)/dtheta_j dtheta_k = w . J dQ/dtheta_k`` for j < k depends on k alone, so the Hessian
  has O(n) distinct entries and O(n^2) references.

Each per-segment template is reduced by ``sympy.cse`` once and then instantiated n times, so
the program has O(n) assignments plus the O(n^2) Hessian references.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from . import energy
from . import symbols as S
from .effects import EffectSet, check_segments, check_variant
from .kinematics import chain_sum_derivatives, chord, fraction_in_segment


@dataclass
class FunctionSpec:
    """One CasADi Function to emit: its input names and its named outputs."""

    inputs: list[str]
    outputs: dict[str, list[list[sp.Expr]]]  # each output a matrix, as a list of rows
    doc: str


@dataclass
class Program:
    """A straight-line program: ordered assignments, then Functions of named inputs."""

    n: int
    effects: EffectSet
    variant: str
    inputs: dict[str, list[sp.Symbol]]
    assignments: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    functions: dict[str, FunctionSpec] = field(default_factory=dict)


class _Builder:
    def __init__(self) -> None:
        self.assignments: list[tuple[sp.Symbol, sp.Expr]] = []
        self.names: set[str] = set()
        self.templates: dict[str, tuple[list, list]] = {}

    def assign(self, name: str, expr: sp.Expr) -> sp.Expr:
        """Record ``name = expr`` unless expr is atomic; return what stands for it."""
        expr = sp.sympify(expr)
        if expr.is_Atom:
            return expr
        assert name not in self.names, name
        self.names.add(name)
        sym = sp.Symbol(name)
        self.assignments.append((sym, expr))
        return sym

    def template(self, key: str, exprs: list[sp.Expr]) -> None:
        """Reduce a per-segment template by common-subexpression elimination, once."""
        repl, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("_c"), order="canonical")
        self.templates[key] = (repl, reduced)

    def instantiate(self, key: str, prefix: str, mapping: dict) -> list[sp.Expr]:
        """Emit the template's assignments with ``mapping`` applied; return its outputs."""
        repl, reduced = self.templates[key]
        local = dict(mapping)
        for k, (sym, expr) in enumerate(repl):
            local[sym] = self.assign(f"{prefix}_{k}", expr.xreplace(local))
        return [e.xreplace(local) for e in reduced]


def _chord_template(b: _Builder, key: str, n: int, sigma) -> None:
    c = chord(S.t, sigma, n)
    dc = c.diff(S.t)
    ddc = dc.diff(S.t)
    b.template(key, [c[0], c[1], dc[0], dc[1], ddc[0], ddc[1]])


def _vec3(vals: list[sp.Expr]) -> tuple[tuple, tuple, tuple]:
    """(chord, d chord, d2 chord) as three plane vectors."""
    return tuple(vals[0:2]), tuple(vals[2:4]), tuple(vals[4:6])


def _column(values) -> list[list[sp.Expr]]:
    return [[v] for v in values]


def _dot(w: tuple, a: tuple) -> sp.Expr:
    return w[0] * a[0] + w[1] * a[1]


def _dot_J(w: tuple, a: tuple) -> sp.Expr:
    """w . (J a), J the rotation by +90 degrees: J (a_x, a_y) = (-a_y, a_x)."""
    return -w[0] * a[1] + w[1] * a[0]


def build(n: int, effects: EffectSet, variant: str = "paper") -> Program:
    """Build the straight-line program of the n-segment model with the given effects."""
    n = check_segments(n)
    check_variant(variant)
    b = _Builder()
    th = S.theta(n)
    params = {name: [S.by_name(name)] for name in effects.parameters()}
    inputs = {"theta": th, **params}

    # --- cumulative angles phi_k = theta_1 + ... + theta_{k-1} (phi_1 = 0)
    cos_phi: list[sp.Expr] = [sp.Integer(1)]
    sin_phi: list[sp.Expr] = [sp.Integer(0)]
    phi = sp.Integer(0)
    for k in range(2, n + 1):
        phi = b.assign(f"phi{k}", phi + th[k - 2])
        cos_phi.append(b.assign(f"cphi{k}", sp.cos(phi)))
        sin_phi.append(b.assign(f"sphi{k}", sp.sin(phi)))
    total_angle = b.assign("theta_TOL", phi + th[n - 1])  # Eq. (17)

    def rotate(k: int, a: tuple) -> tuple:
        return (cos_phi[k] * a[0] - sin_phi[k] * a[1], sin_phi[k] * a[0] + cos_phi[k] * a[1])

    # --- separable terms: per-segment summands, their sum, first and second derivative
    sep = energy.separable(effects.names(), n, variant)
    term_names = list(sep)
    u = sum(sep.values(), sp.Integer(0))
    b.template("seg", [*sep.values(), sp.diff(u, S.t), sp.diff(u, S.t, 2)])
    term_sums = {name: sp.Integer(0) for name in term_names}
    du: list[sp.Expr] = []
    ddu: list[sp.Expr] = []
    for i in range(n):
        vals = b.instantiate("seg", f"u{i + 1}", {S.t: th[i]})
        for name, val in zip(term_names, vals):
            term_sums[name] += val
        du.append(vals[-2])
        ddu.append(vals[-1])

    # --- the full chord of every segment (kinematics, gravity)
    _chord_template(b, "c1", n, sp.Integer(1))
    c1 = [_vec3(b.instantiate("c1", f"c{i + 1}", {S.t: th[i]})) for i in range(n)]

    grad = list(du)
    hess_diag = list(ddu)
    hess_off = [sp.Integer(0)] * n  # hess_off[k]: the entry (j, k) for every j < k
    terms_out: dict[str, sp.Expr] = {name: b.assign(f"U_{name}", term_sums[name]) for name in term_names}

    def add_potential(tag: str, w: tuple, v, dv, ddv) -> sp.Expr:
        """Add w . Q(theta) for the chain sum Q with local vectors v to gradient and Hessian."""
        Q, D, DD, _ = chain_sum_derivatives(cos_phi, sin_phi, v, dv, ddv, b.assign, tag)
        for j in range(n):
            grad[j] = grad[j] + _dot(w, D[j])
            hess_diag[j] = hess_diag[j] + _dot(w, DD[j])
            hess_off[j] = hess_off[j] + _dot_J(w, D[j])
        return _dot(w, Q)

    # --- payloads (Eq. 14): -f . (p(s) - p_straight(s)), p(s) a chain sum with fractions sigma
    if effects.payloads:
        _chord_template(b, "cs", n, S.sigma)
    for k in range(1, effects.payloads + 1):
        F, Om, s = S.payload(k)
        sig = [b.assign(f"sig{k}_{i + 1}", fraction_in_segment(s, i + 1, n)) for i in range(n)]
        cs = [_vec3(b.instantiate("cs", f"p{k}c{i + 1}", {S.t: th[i], S.sigma: sig[i]})) for i in range(n)]
        f = energy.force_vector(F, Om)
        w = (b.assign(f"w{k}_x", -f[0]), b.assign(f"w{k}_y", -f[1]))
        pot = add_potential(f"pl{k}", w, [c[0] for c in cs], [c[1] for c in cs], [c[2] for c in cs])
        terms_out[f"payload{k}"] = b.assign(f"U_payload{k}", pot + f[0] * s * S.L)

    # --- gravity (Eq. 15): weight M g / n at every mid-point. Summed over the mid-points, the
    # chain sum has local vectors (n - k) c(theta_k; 1) + c(theta_k; 1/2) (segment k lies wholly
    # before the n - k mid-points beyond it and half before its own).
    if effects.gravity:
        _chord_template(b, "ch", n, sp.Rational(1, 2))
        ch = [_vec3(b.instantiate("ch", f"h{i + 1}", {S.t: th[i]})) for i in range(n)]
        vg = [[((n - 1 - i) * c1[i][m][0] + ch[i][m][0], (n - 1 - i) * c1[i][m][1] + ch[i][m][1]) for m in range(3)] for i in range(n)]
        w = (b.assign("wg_x", -S.M * S.g / n), sp.Integer(0))
        pot = add_potential("gr", w, [v[0] for v in vg], [v[1] for v in vg], [v[2] for v in vg])
        terms_out["gravity"] = b.assign("U_gravity", pot + S.M * S.g * S.L / 2)

    U = b.assign("U", sum(terms_out.values(), sp.Integer(0)))
    g_syms = [b.assign(f"grad{j + 1}", grad[j]) for j in range(n)]
    hd = [b.assign(f"hdiag{j + 1}", hess_diag[j]) for j in range(n)]
    # hess_off[0] would be the entry above the first diagonal one: there is none
    ho = [sp.Integer(0)] + [b.assign(f"hoff{j + 1}", hess_off[j]) for j in range(1, n)]
    H = [[hd[i] if i == j else ho[max(i, j)] for j in range(n)] for i in range(n)]

    # --- kinematics: segment end points (heads of the chain) and the tip pose
    pts = [(sp.Integer(0), sp.Integer(0))]
    for i in range(n):
        r = rotate(i, c1[i][0])
        pts.append((b.assign(f"pt{i + 1}_x", pts[-1][0] + r[0]), b.assign(f"pt{i + 1}_y", pts[-1][1] + r[1])))
    points = [[p[0] for p in pts], [p[1] for p in pts]]
    tip = _column([pts[-1][0], pts[-1][1], total_angle])

    # --- centreline: the point at fraction s_c of L (and the heading there)
    s_c = sp.Symbol("s", real=True)
    sig_c = [b.assign(f"sigc{i + 1}", fraction_in_segment(s_c, i + 1, n)) for i in range(n)]
    b.template("cc", list(chord(S.t, S.sigma, n)))
    pcx, pcy, heading = [], [], []
    for i in range(n):
        cv = b.instantiate("cc", f"cc{i + 1}", {S.t: th[i], S.sigma: sig_c[i]})
        r = rotate(i, cv)
        pcx.append(r[0])
        pcy.append(r[1])
        heading.append(sig_c[i] * th[i])
    centre = _column([b.assign("cl_x", sp.Add(*pcx)), b.assign("cl_y", sp.Add(*pcy)), b.assign("cl_heading", sp.Add(*heading))])

    pnames = ["theta", *effects.parameters()]
    terms_vec = _column([terms_out[name] for name in effects.terms()])
    functions = {
        "energy": FunctionSpec(pnames, {"U": [[U]], "terms": terms_vec}, "total potential energy U (N*mm) and its terms, in the order of TERMS"),
        "gradient": FunctionSpec(pnames, {"grad": _column(g_syms)}, "dU/dtheta (N*mm/rad)"),
        "hessian": FunctionSpec(pnames, {"hess": H}, "d2U/dtheta2 (N*mm/rad^2), dense and symmetric"),
        "kinematics": FunctionSpec(["theta", "L"], {"tip": tip, "points": points}, "tip [x, y, angle] (mm, mm, rad) and the n+1 segment end points (2 x (n+1), mm)"),
        "centreline": FunctionSpec(["theta", "L", "s"], {"point": centre}, "the point [x, y, heading] at fraction s of L from the base"),
    }
    inputs["s"] = [s_c]
    return Program(n, effects, variant, inputs, b.assignments, functions)
