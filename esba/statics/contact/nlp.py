"""The contact NLP: min U(theta) subject to gap >= 0 at every point where the body can touch, on IPOPT.

For each obstacle k and each segment i two constraints:

* the gap at joint i (the end of segment i, the tip for i = n), and
* the gap at the point sigma_ki of segment i (a parameter): its interior local minimum when it has
  one (:func:`esba.model.contact.surface.closest_points`), else its midpoint.

With sigma_ki at the minimum, d(gap)/d(sigma) = 0 there, so the constraint's gradient in theta at
fixed sigma is the gradient of the segment's least gap (the envelope theorem): the KKT conditions of
this NLP are those of contact along whole segments. Its Hessian is not (the least gap's Hessian has
the term -g_theta,sigma g_sigma,sigma^-1 g_sigma,theta); :mod:`.equilibrium` adds it for the
second-order check. Two more constraints fix the tip's x and y when a displacement is prescribed
(bounds +-inf otherwise): their multipliers are the reaction forces.

The energy's gradient and Hessian are the generated ones; the constraints' derivatives come from
CasADi's AD on the closed-form chain (:func:`esba.model.contact.surface.symbolic_surface`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import casadi as ca

from esba.model.contact.obstacles import OBSTACLE_KINDS
from esba.model.contact.surface import symbolic_surface
from esba.model.generated import Model

__all__ = ["ContactNLP", "contact_nlp", "parameter_size"]


def parameter_size(kind: str) -> int:
    """How many numbers an obstacle of ``kind`` hands the NLP (its own, then offset and n fractions)."""
    return {"half-plane": 4, "cylinder": 3}[kind]


@dataclass(frozen=True, eq=False)
class ContactNLP:
    """IPOPT and the functions of the KKT check for one model and one tuple of obstacle kinds.

    ``solver(x0, p, lbx, lbg, ubg, lam_g0, lam_x0)``; ``terms(x, p, lam_g)`` -> gaps (m), their
    Jacobian (m x n), dU/dtheta, d2U/dtheta2, the Hessian of lam_g . g and the tip [x, y, angle];
    ``interior(x, p)`` -> for the interior points: d(gap)/dsigma, d2(gap)/dsigma2 and d2(gap)/dtheta dsigma
    (K n x n). Constraint order: per obstacle the n joints then the n interior points, then tip x, tip y.
    """

    solver: ca.Function
    warm_solver: ca.Function
    terms: ca.Function
    interior: ca.Function
    kinds: tuple[str, ...]
    n: int

    @property
    def constraints(self) -> int:
        return 2 * self.n * len(self.kinds) + 2


def contact_nlp(model: Model, kinds: Sequence[str], tol: float = 1e-10, max_iter: int = 200, linear_solver: str = "mumps") -> ContactNLP:
    """The :class:`ContactNLP` of ``model`` with obstacles of ``kinds`` (built once per model and settings)."""
    kinds = tuple(kinds)
    return model.derived("contact_nlp", lambda: _build(model, kinds, tol, max_iter, linear_solver), settings=(kinds, tol, max_iter, linear_solver), persist=False)


def _build(model: Model, kinds: tuple[str, ...], tol: float, max_iter: int, linear_solver: str) -> ContactNLP:
    n, names = model.n, model.parameters
    x = ca.SX.sym("theta", n)
    pm = ca.SX.sym("p", len(names))
    args = ca.vertsplit(pm)
    length = pm[names.index("L")]
    u = model["energy"](x, *args)[0]
    grad = model["gradient"](x, *args)
    hess = model["hessian"](x, *args)
    tip = model["kinematics"](x, length)[0]
    gaps, inside, sigmas, ps = [], [], [], [pm]
    for k, kind in enumerate(kinds):
        cls = OBSTACLE_KINDS[kind][0]
        par = ca.SX.sym(f"obstacle{k}", parameter_size(kind))
        offset = ca.SX.sym(f"offset{k}")
        sigma = ca.SX.sym(f"sigma{k}", n)
        ps += [par, offset, sigma]
        joints, points = symbolic_surface(x, length, offset, sigma)
        gaps += [cls.symbolic_distance(q, par) for q in joints]
        mid = [cls.symbolic_distance(q, par) for q in points]
        gaps += mid
        inside += mid
        sigmas.append(sigma)
    g = ca.vertcat(*gaps, tip[0], tip[1])
    p = ca.vertcat(*ps)
    lam_f = ca.SX.sym("lam_f")
    lam_g = ca.SX.sym("lam_g", g.shape[0])
    hess_g = ca.hessian(ca.dot(lam_g, g), x)[0]
    grad_f = ca.Function("grad_f", [x, p], [u, grad], ["x", "p"], ["f", "grad_f"])
    hess_lag = ca.Function("hess_lag", [x, p, lam_f, lam_g], [ca.triu(lam_f * hess + hess_g)], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])

    def solver(warm: bool) -> ca.Function:
        opts = {
            "grad_f": grad_f,
            "hess_lag": hess_lag,
            "print_time": False,
            "calc_lam_p": False,
            "show_eval_warnings": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": tol,
            "ipopt.max_iter": max_iter,
            "ipopt.linear_solver": linear_solver,
        }
        if warm:  # the start is the previous equilibrium of a sweep, with its multipliers
            opts.update({"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-8, "ipopt.warm_start_bound_push": 1e-9,
                         "ipopt.warm_start_mult_bound_push": 1e-9, "ipopt.warm_start_slack_bound_push": 1e-9})
        return ca.nlpsol("esba_contact", "ipopt", {"x": x, "f": u, "g": g, "p": p}, opts)

    jac_g = ca.jacobian(g, x)
    terms = ca.Function("contact_terms", [x, p, lam_g], [g, jac_g, grad, hess, hess_g, tip], ["theta", "p", "lam_g"], ["g", "jac_g", "grad", "hess", "hess_g", "tip"])
    if inside:
        gi, sg = ca.vertcat(*inside), ca.vertcat(*sigmas)
        ds = ca.diag(ca.jacobian(gi, sg))
        dss = ca.diag(ca.jacobian(ds, sg))
        dxs = ca.jacobian(ds, x)
    else:  # no obstacle: only a prescribed displacement
        ds = dss = ca.SX(0, 1)
        dxs = ca.SX(0, n)
    interior = ca.Function("contact_interior", [x, p], [ds, dss, dxs], ["theta", "p"], ["d_sigma", "d_sigma2", "d_theta_sigma"])
    return ContactNLP(solver(False), solver(True), terms, interior, kinds, n)
