"""The section by finite elements (scikit-fem): the structured, isoparametric P2 mesh of the eccentric
annulus, Prandtl's stress function with the chamber's constant (J from below), the warping function
(J from above, the shear centre). See :mod:`esba.model.section` for the formulas.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from esba.infra import checks
from esba.infra.threads import blas_one_thread

from .geometry import SectionError, check_geometry

__all__ = ["MESH_LEVELS", "DEFAULT_MESH", "FESection", "finite_elements", "annulus_mesh", "check_mesh"]

#: Mesh levels: (radial layers, divisions around). Level k doubles both of level k - 1.
MESH_LEVELS = {k: (3 * 2**k, 24 * 2**k) for k in range(0, 6)}
#: The default level: J within 1e-5 relative (its bracket by the warping function) at the Table 1 section, in about 0.1 s.
DEFAULT_MESH = 2


def check_mesh(mesh: Any) -> int:
    """A mesh level of :data:`MESH_LEVELS` (a :class:`SectionError` naming it otherwise)."""
    return checks.whole("mesh", mesh, 0, SectionError, high=max(MESH_LEVELS), why="each level doubles the mesh both ways; level 5 takes minutes and resolves J to 1e-9")


@dataclass(frozen=True)
class FESection:
    """What the finite elements give for the section (mm units), each an approximation on ``mesh``.

    ``area``, ``centroid``, ``I_yy``, ``I_zz``, ``I_yz`` as in :class:`SectionProperties` (the API
    uses the closed forms; these check the mesh); ``J_lower`` from Prandtl's stress function (the
    complementary energy: a lower bound), ``J_upper`` from the warping function (the potential
    energy: an upper bound); ``hole_constant`` the stress function's value C on the chamber;
    ``shear_centre`` (Trefftz) in the frame of the module.
    """

    area: float
    centroid: tuple[float, float]
    I_yy: float
    I_zz: float
    I_yz: float
    J_lower: float
    J_upper: float
    hole_constant: float
    shear_centre: tuple[float, float]
    mesh: int


def blend(r1: float, r2: float, d: float, s, t):
    """The map of (s, t) to (y, z): the chamber's circle at s = 0, the outer one at s = 1."""
    import numpy as np

    yc = -(r1 + d)  # the chamber's centre; the disc's centre is at -r1
    y = (1 - s) * (yc + r2 * np.cos(t)) + s * (-r1 + r1 * np.cos(t))
    z = (1 - s) * r2 * np.sin(t) + s * r1 * np.sin(t)
    return y, z


def annulus_mesh(r1: float, r2: float, d: float, level: int):
    """A quadratic isoparametric triangle mesh of the section and the chamber's and outer boundary facets."""
    import numpy as np
    from skfem import MeshTri1, MeshTri2

    nr, nt = MESH_LEVELS[level]
    s = np.linspace(0.0, 1.0, nr + 1)
    # divisions around, closer toward the thin wall at t = pi: t = tau + beta sin(tau) spaces them
    # by (1 - beta) there and (1 + beta) at the thick wall, beta = 1 - sqrt(thin / thick wall)
    beta = 1 - math.sqrt((r1 - r2 - d) / (r1 - r2 + d))
    tau = np.linspace(0.0, 2 * np.pi, nt + 1)[:-1]
    t = tau + beta * np.sin(tau)
    S, T = np.meshgrid(s, t, indexing="ij")  # node (i, j) is i * nt + j
    y, z = blend(r1, r2, d, S.ravel(), T.ravel())
    idx = np.arange((nr + 1) * nt).reshape(nr + 1, nt)
    a, b = idx[:-1, :], np.roll(idx[:-1, :], -1, axis=1)
    c, e = idx[1:, :], np.roll(idx[1:, :], -1, axis=1)
    # each quad (a b e c) split along a diagonal, a-e for t in [0, pi) and b-c for t in [pi, 2 pi):
    # the mesh is the mirror image of itself in z -> -z, as the section is
    up = (np.arange(nt) < nt // 2)[None, :].repeat(nr, axis=0).ravel()
    a, b, c, e = a.ravel(), b.ravel(), c.ravel(), e.ravel()
    first = np.where(up, np.vstack([a, b, e]), np.vstack([a, b, c]))
    second = np.where(up, np.vstack([a, e, c]), np.vstack([b, e, c]))
    tri = np.hstack([first, second])
    linear = MeshTri1(np.vstack([y, z]), tri)
    quad = MeshTri2.from_mesh(linear)
    # place every node (vertices and edge mid-points) by the map: the parameters of a node are
    # the mean of its edge's ends, with the angle unwrapped across t = 2 pi
    sp, tp = S.ravel(), T.ravel()
    doflocs = quad.doflocs.copy()
    edges = quad.facets  # 2 x nfacets, vertex indices (the edges, in 2-D; their dofs follow the vertices)
    s_mid = 0.5 * (sp[edges[0]] + sp[edges[1]])
    dt = np.angle(np.exp(1j * (tp[edges[1]] - tp[edges[0]])))
    t_mid = tp[edges[0]] + 0.5 * dt
    ey, ez = blend(r1, r2, d, s_mid, t_mid)
    nv = linear.nvertices
    doflocs[:, nv : nv + edges.shape[1]] = np.vstack([ey, ez])
    from dataclasses import replace

    quad = replace(quad, doflocs=doflocs)
    inner_v = np.zeros(nv, bool)
    inner_v[idx[0]] = True
    outer_v = np.zeros(nv, bool)
    outer_v[idx[-1]] = True
    f = quad.facets
    inner_f = np.nonzero(inner_v[f[0]] & inner_v[f[1]])[0]
    outer_f = np.nonzero(outer_v[f[0]] & outer_v[f[1]])[0]
    return quad, inner_f, outer_f


def finite_elements(r1: float, r2: float, d: float, *, mesh: int = DEFAULT_MESH) -> FESection:
    """The section by finite elements (P2, isoparametric) on mesh level ``mesh``; cached by its inputs.

    >>> fe = finite_elements(8.0, 3.0, 0.0, mesh=1)
    >>> round(fe.hole_constant, 3), round(fe.J_lower / (3.14159265358979 * (8**4 - 3**4) / 2), 5)
    (27.5, 1.0)
    """
    r1, r2, d = check_geometry(r1, r2, d)
    return _finite_elements(r1, r2, d, check_mesh(mesh))


def _finite_elements(r1: float, r2: float, d: float, level: int) -> FESection:
    """The section of radius r1 from the one of radius 1 (cached by the ratios r2/r1, d/r1)."""
    u = _unit_section(r2 / r1, d / r1, level)
    return FESection(
        area=u.area * r1**2,
        centroid=(u.centroid[0] * r1, u.centroid[1] * r1),
        I_yy=u.I_yy * r1**4,
        I_zz=u.I_zz * r1**4,
        I_yz=u.I_yz * r1**4,
        J_lower=u.J_lower * r1**4,
        J_upper=u.J_upper * r1**4,
        hole_constant=u.hole_constant * r1**2,
        shear_centre=(u.shear_centre[0] * r1, u.shear_centre[1] * r1),
        mesh=level,
    )


@lru_cache(maxsize=64)
def _unit_section(r2: float, d: float, level: int) -> FESection:
    """The finite elements on the section of r1 = 1 (one BLAS thread: the work is sparse)."""
    with blas_one_thread():
        return _unit_fe(r2, d, level)


def _unit_fe(r2: float, d: float, level: int) -> FESection:
    r1 = 1.0
    import numpy as np
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve
    from skfem import Basis, BilinearForm, ElementTriP2, LinearForm
    from skfem.helpers import dot, grad

    mesh, inner_f, outer_f = annulus_mesh(r1, r2, d, level)
    basis = Basis(mesh, ElementTriP2(), intorder=4)

    @BilinearForm
    def laplace(u, v, w):
        return dot(grad(u), grad(v))

    @LinearForm
    def two(v, w):
        return 2.0 * v

    K = laplace.assemble(basis).tocsr()
    f = two.assemble(basis)
    N = K.shape[0]
    ones = np.ones(N)
    m1 = LinearForm(lambda v, w: v).assemble(basis)  # ∫ v dA
    area = float(m1.sum())
    yc = float(LinearForm(lambda v, w: w.x[0] * v).assemble(basis).sum()) / area
    zc = float(LinearForm(lambda v, w: w.x[1] * v).assemble(basis).sum()) / area

    # Prandtl: phi = 0 on the outer circle, phi = C on the chamber (one unknown), circulation by stationarity
    hole = basis.get_dofs(facets=inner_f).all()
    outer = basis.get_dofs(facets=outer_f).all()
    free = np.setdiff1d(np.arange(N), np.union1d(hole, outer))
    rows = np.concatenate([free, hole])
    cols = np.concatenate([np.arange(free.size), np.full(hole.size, free.size)])
    T = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(N, free.size + 1))
    a_hole = math.pi * r2**2
    Kr = (T.T @ K @ T).tocsc()
    fr = T.T @ f
    fr[-1] += 2.0 * a_hole
    u = spsolve(Kr, fr, permc_spec="MMD_AT_PLUS_A")
    J_phi = float(fr @ u)  # = 2 ∫ phi dA + 2 C A_chamber

    # warping about the centroid: ∫ ∇omega·∇v = ∫ (z' v_y - y' v_z), omega fixed at one node
    @LinearForm
    def rot(v, w):
        yy, zz = w.x[0] - yc, w.x[1] - zc
        return zz * v.grad[0] - yy * v.grad[1]

    g = rot.assemble(basis)
    # omega is fixed at one node, then shifted to ∫ omega dA = 0 (the constant does no work)
    keep = np.arange(1, N)
    omega = np.zeros(N)
    omega[keep] = spsolve(K[keep][:, keep].tocsc(), g[keep], permc_spec="MMD_AT_PLUS_A")
    omega -= (m1 @ omega) / m1.sum()

    def moment(fun):
        return LinearForm(lambda v, w: fun(w.x[0] - yc, w.x[1] - zc) * v).assemble(basis)

    Ip = float(moment(lambda y, z: y**2 + z**2) @ ones)
    J_omega = Ip - float(omega @ (K @ omega))
    Iyw, Izw = float(moment(lambda y, z: y) @ omega), float(moment(lambda y, z: z) @ omega)
    Iy2, Iz2 = float(moment(lambda y, z: y**2) @ ones), float(moment(lambda y, z: z**2) @ ones)
    Iyz = float(moment(lambda y, z: y * z) @ ones)
    # omega_P = omega_c - z_s y + y_s z orthogonal to y and z (centroidal):
    #   Iyz y_s - Iy2 z_s = -Iyw ;  Iz2 y_s - Iyz z_s = -Izw
    ys, zs = np.linalg.solve([[Iyz, -Iy2], [Iz2, -Iyz]], [-Iyw, -Izw])
    return FESection(
        area=area,
        centroid=(yc, zc),
        I_yy=Iz2,  # ∫ z'² dA: about the axis parallel to y
        I_zz=Iy2,  # ∫ y'² dA: about the axis parallel to z
        I_yz=Iyz,
        J_lower=J_phi,
        J_upper=J_omega,
        hole_constant=float(u[-1]),
        shear_centre=(float(yc + ys), float(zc + zs)),
        mesh=level,
    )
