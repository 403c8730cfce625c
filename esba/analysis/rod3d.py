"""The field's rod benchmarks on esba's spatial machinery (the ``rod`` variant), with their references.

B1  Euler's elastica: a cantilever under a tip dead load perpendicular to its axis, alpha = P L^2/EI.
    Reference: the elliptic-integral solution that Mattiasson (1981) tabulates, computed here by
    quadrature of  sqrt(2 alpha) = int_0^phi0 dphi / sqrt(sin phi0 - sin phi)  (phi the tangent's
    angle, phi0 at the tip), with the tip at  x/L = sqrt(2 sin phi0 / alpha),
    y/L = int_0^phi0 sin phi dphi / sqrt(sin phi0 - sin phi) / sqrt(2 alpha).
    The n -> infinity limit: the piecewise-constant-curvature chain converges as 1/n^2, so
    Richardson's extrapolation (4 f(2n) - f(n)) / 3 removes the leading term.
B2  Roll-up: an end moment M = 2 pi EI / L bends the rod into a full circle; reached by
    continuation in the moment (the rod's discrete chain is exact for a circle at any n).
B5  Prandtl's lateral-torsional buckling: a cantilever loaded at its tip in its stiff plane
    buckles sideways at P_cr = 4.0126 sqrt(EI_side GJ) / L^2 (EI_side / EI -> 0). Found as the
    load at which the 3n x 3n Hessian of the in-plane equilibrium becomes singular with a
    sideways-twist mode (a branch point), and extrapolated in n as B1.
B6  Twist buckling under an end torque (Greenhill's problem on a cantilever): a couple of dead forces
    on a rigid arm at the tip (the ``couple`` load; an arm along y, forces along z: the torque T = M
    about the axis at the straight state) twists the rod by phi0 with GJ phi0 / L = M cos phi0, and
    the twisted state of an isotropic rod (EI both ways) turns unstable at the twisting moment
        T_cr = (pi / 2L) EI GJ / (GJ - EI)        (only when GJ > EI; none when GJ <= EI)
    (linearised about the twisted state, derived in docs/3d.md; T_cr -> pi EI / 2L as GJ -> infinity).
    Found as a Hessian zero on the twisted state and extrapolated in n as B1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate, optimize

from esba.model.spatial import Model3D, load_model3d
from esba.statics.spatial import newton3d

#: Prandtl's coefficient for a tip load at the centroid of a narrow cantilever (Timoshenko & Gere,
#: Theory of Elastic Stability, 1961, Sect. 6.3: gamma_1 = 4.013).
PRANDTL = 4.0126


def rod_values(L: float = 1.0, EI: float = 1.0, EI_side: float = 1.0, GJ: float = 1.0, kappa0: float = 0.0, *,
               F: float = 0.0, Omega: float = np.pi / 2, Beta: float = 0.0, s: float = 1.0) -> dict[str, float]:
    return dict(L=L, EI=EI, EI_side=EI_side, GJ=GJ, kappa0=kappa0, F1=F, Omega1=Omega, Beta1=Beta, s1=s)


def elastica_reference(alpha: float) -> dict[str, float]:
    """Tip of the exact elastica (B1): v/L (deflection), 1 - u/L... as x/L, and the tip angle phi0."""

    # substitute sin(phi) = sin(phi0) (1 - t^2) to remove the endpoint singularity; the factor
    # 1 - sin(phi)^2 = (1 - s0 u)(1 + s0 u), u = 1 - t^2, with 1 - s0 = 2 sin^2((pi/2 - phi0)/2) free of cancellation
    def integrand(phi0: float, weight: bool):
        s0 = np.sin(phi0)
        gap = 2.0 * np.sin((np.pi / 2 - phi0) / 2) ** 2

        def f(t: float) -> float:
            u = 1.0 - t * t
            value = 2.0 * np.sqrt(s0) / np.sqrt((gap + s0 * t * t) * (1.0 + s0 * u))
            return s0 * u * value if weight else value

        return f

    def length_t(phi0: float) -> float:
        return integrate.quad(integrand(phi0, False), 0.0, 1.0, epsabs=1e-12, epsrel=1e-12, limit=200)[0] - np.sqrt(2.0 * alpha)

    # alpha = 10 has phi0 = 1.43; pi/2 - 1e-3 holds alpha up to about 25
    phi0 = optimize.brentq(length_t, 1e-9, np.pi / 2 - 1e-3, xtol=1e-15)
    s0 = np.sin(phi0)
    y = integrate.quad(integrand(phi0, True), 0.0, 1.0, epsabs=1e-12, epsrel=1e-12, limit=200)[0] / np.sqrt(2.0 * alpha)
    x = np.sqrt(2.0 * s0 / alpha)
    return {"v": y, "u": 1.0 - x, "phi0": phi0}


def _tip_along_load(model: Model3D, alpha: float, steps: int = 10) -> np.ndarray:
    vals = rod_values(F=0.0, Omega=-np.pi / 2)  # the force along +y: the rod bends toward +y
    q = np.zeros(model.size)
    for lam in np.linspace(0, 1, steps + 1)[1:]:
        vals["F1"] = lam * alpha
        q, ok, _ = newton3d(model, vals, q)
        if not ok:
            raise RuntimeError(f"B1: Newton did not converge at alpha = {lam * alpha:g}, n = {model.n}")
    return q


def elastica(n: int, alpha: float) -> dict[str, float]:
    """B1 on the n-segment rod: v/L, u/L (shortening), tip angle (rad); L = EI = 1."""
    model = load_model3d(n, "rod,payload")
    q = _tip_along_load(model, alpha)
    tip, _, _ = model.pose(q, 1.0)
    return {"v": float(tip[1]), "u": float(1.0 - tip[0]), "phi0": float(np.sum(q[:n]))}


def richardson(f_n: float, f_2n: float) -> float:
    """(4 f(2n) - f(n)) / 3: the n -> infinity limit of a quantity converging as 1/n^2."""
    return (4.0 * f_2n - f_n) / 3.0


@dataclass
class BranchPoint:
    load: float
    mode: np.ndarray
    q: np.ndarray


def lateral_torsional_load(n: int, EI_side: float = 1.0, GJ: float = 1.0, EI: float = 1e6, L: float = 1.0) -> BranchPoint:
    """B5: the tip load in the stiff plane at which the in-plane equilibrium's Hessian turns singular.

    The in-plane state (psi = tau = 0) is followed by Newton; its sideways-twist block decouples
    from theta (the restriction to the plane), and its smallest eigenvalue is brought to zero by
    Brent's method in the load.
    """
    model = load_model3d(n, "rod,payload")
    vals = rod_values(L=L, EI=EI, EI_side=EI_side, GJ=GJ, Omega=np.pi / 2)
    state = {"q": np.zeros(model.size)}

    def min_eig(F: float) -> float:
        vals["F1"] = F
        q, ok, _ = newton3d(model, vals, state["q"])
        state["q"] = q
        H = model.hessian(q, vals)
        return float(np.linalg.eigvalsh(H)[0])

    guess = PRANDTL * np.sqrt(EI_side * GJ) / L**2
    lo, hi = 0.5 * guess, 0.5 * guess
    while min_eig(hi) > 0:
        lo, hi = hi, hi * 1.25
    F = optimize.brentq(min_eig, lo, hi, xtol=1e-14, rtol=1e-13)
    vals["F1"] = F
    w, V = np.linalg.eigh(model.hessian(state["q"], vals))
    return BranchPoint(F, V[:, 0], state["q"])


def greenhill_reference(EI: float = 1.0, GJ: float = 10.0, L: float = 1.0) -> tuple[float, float, float] | None:
    """B6's closed form: (T_cr, phi0, M_cr), the twisting moment, the pre-buckling twist and the
    couple's moment at the branch point; None when GJ <= EI (the twisted state never buckles)."""
    if GJ <= EI:
        return None
    T = np.pi / (2.0 * L) * EI * GJ / (GJ - EI)
    phi0 = T * L / GJ
    return T, phi0, T / np.cos(phi0)


def couple_values(L: float = 1.0, EI: float = 1.0, GJ: float = 10.0, M: float = 0.0) -> dict[str, float]:
    """An isotropic rod (EI both ways) with the end couple of B6: moment (M, 0, 0), arm along y."""
    return dict(L=L, EI=EI, EI_side=EI, GJ=GJ, kappa0=0.0, cx1=M, cy1=0.0, cz1=0.0, ax1=0.0, ay1=1.0, az1=0.0, sc1=1.0)


def twist_buckling_couple(n: int, EI: float = 1.0, GJ: float = 10.0, L: float = 1.0, top: float | None = None) -> BranchPoint | None:
    """B6: the end couple at which the twisted equilibrium's Hessian turns singular, or None when
    it stays positive definite up to ``top`` (default: 20 pi EI / L).

    The twisted state (theta = psi = 0, the twist uniform) is followed by Newton in the couple;
    the smallest eigenvalue is bracketed in steps of 10 % and brought to zero by Brent's method.
    """
    model = load_model3d(n, "rod,couple")
    vals = couple_values(L, EI, GJ)
    state = {"q": np.zeros(model.size)}
    top = 20.0 * np.pi * EI / L if top is None else top

    def min_eig(M: float) -> float:
        vals["cx1"] = M
        q, ok, _ = newton3d(model, vals, state["q"])
        if not ok:
            raise RuntimeError(f"B6: Newton did not converge at M = {M:g}, n = {n}")
        state["q"] = q
        return float(np.linalg.eigvalsh(model.hessian(q, vals))[0])

    lo = hi = 0.05 * np.pi * EI / L
    while min_eig(hi) > 0:
        lo, hi = hi, hi * 1.1
        if hi > top:
            return None
    M = optimize.brentq(min_eig, lo, hi, xtol=1e-14, rtol=1e-13)
    vals["cx1"] = M
    w, V = np.linalg.eigh(model.hessian(state["q"], vals))
    return BranchPoint(M, V[:, 0], state["q"])


# ---------------------------------------------------------------------------------------------
# B3: the Bathe-Bolourchi 45 degree bend

#: Bathe & Bolourchi (1979): a 45 degree arc of radius 100 in the plane, square section 1 x 1,
#: E = 1e7, G = E/2 (nu = 0), I = 1/12, J = 1/6 (the polar moment, as the references take it),
#: clamped at one end, a dead load P out of the plane at the other.
BATHE = {"R": 100.0, "EI": 1e7 / 12, "GJ": 5e6 / 6}

#: Tip positions (x toward the arc's centre, y along the clamped tangent, z along the load) as the
#: references publish them: Bathe & Bolourchi (1979), Simo & Vu-Quoc (1986), Cardona & Geradin
#: (1988), Crisfield (1990), each with 8 elements.
BATHE_REFERENCES = {
    300.0: {"Bathe-Bolourchi": (22.5, 59.2, 39.5), "Simo-Vu-Quoc": (22.33, 58.84, 40.08)},
    450.0: {"Simo-Vu-Quoc": (18.62, 52.32, 48.39)},
    600.0: {"Bathe-Bolourchi": (15.9, 47.2, 53.4), "Simo-Vu-Quoc": (15.79, 47.23, 53.37),
            "Cardona-Geradin": (15.74, 47.15, 53.43), "Crisfield": (15.61, 47.07, 53.56)},
}


def bathe_bolourchi(n: int, loads=(300.0, 450.0, 600.0), steps_per_100: int = 10) -> dict[float, np.ndarray]:
    """B3 on the n-segment rod with rest curvature 1/R: the tip (x, y, z) in the references' axes.

    esba's rod starts along x and bends toward +y; the references start along y and bend toward
    +x: their (x, y, z) is esba's (y, x, z). The load is raised in steps of 100/steps_per_100.
    """
    L = BATHE["R"] * np.pi / 4
    model = load_model3d(n, "rod,payload")
    vals = rod_values(L=L, EI=BATHE["EI"], EI_side=BATHE["EI"], GJ=BATHE["GJ"], kappa0=1.0 / BATHE["R"], Omega=0.0, Beta=np.pi / 2)
    q = np.zeros(model.size)
    q[:n] = L / (n * BATHE["R"])
    out = {}
    top = max(loads)
    for P in np.linspace(0.0, top, int(round(top / 100 * steps_per_100)) + 1)[1:]:
        vals["F1"] = P
        q, ok, _ = newton3d(model, vals, q)
        if not ok:
            raise RuntimeError(f"B3: Newton did not converge at P = {P:g}, n = {n}")
        for want in loads:
            if abs(P - want) < 1e-9:
                tip = model.tip(q, L)
                out[want] = np.array([tip[1], tip[0], tip[2]])
    return out
