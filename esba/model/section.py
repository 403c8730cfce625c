"""The actuator's cross-section: its geometry, torsion constant, shear centre and stiffnesses.

The paper's actuator (Section 2, Fig. 1, Fig. 3) is a silicone disc of radius ``r1`` with a
circular chamber of radius ``r2`` whose centre is offset by ``d`` from the disc's centre, away from
the inextensible layer (Eq. 7: a chamber fibre at angle beta stretches by (r1 + d - r2 cos beta)
theta, the layer being the line at distance r1 from the disc's centre); a nylon mesh close to
the bottom is the inextensible layer (E = 6500 MPa, nu = 0.2 in Section 4.2); Kevlar fibres are
wound in a double helix at the angle rho from the hoop direction (N = (L + r1 theta)/(2 pi r1
tan rho) turns per fibre, Eq. 18).

Frame
-----
The section lies in the (y, z) plane of the base frame S of the README: x down the unbent axis,
y horizontal toward the bending side, z = x × y. The origin is the paper's inextensible line (the
origin of S, on the ventral side). The silicone then spans y in [-2 r1, 0]: the disc's centre is
at (-r1, 0) and the chamber's centre at (-(r1 + d), 0), on the side away from the bend. The
section is symmetric about the y axis (z -> -z).

Second moments are about axes through the centroid (y_c, z_c):

* ``I_yy = ∫ (z - z_c)² dA``, about the axis parallel to y: it resists the *sideways* bend
  (curvature about y, in the x-z plane);
* ``I_zz = ∫ (y - y_c)² dA``, about the axis parallel to z: it resists the paper's in-plane bend
  (the joints of Eq. 2 turn about z);
* ``I_yz = ∫ (y - y_c)(z - z_c) dA`` (zero by the symmetry).

Closed forms (disc minus offset disc, by the parallel-axis theorem; exact, used by the API)::

    A    = pi (r1² - r2²)
    y_c  = -r1 + d r2² / (r1² - r2²)                     (the centroid moves away from the chamber)
    I_yy = pi (r1⁴ - r2⁴) / 4
    I_zz = pi (r1⁴ - r2⁴) / 4 - pi r1² r2² d² / (r1² - r2²)

Torsion (Saint-Venant, finite elements)
---------------------------------------
Prandtl's stress function phi (shear stresses tau_xy = d phi/dz, tau_xz = -d phi/dy per unit
G theta') solves ∇² phi = -2 on the silicone, phi = 0 on the outer circle and phi = C (a constant)
on the chamber's circle: the section is doubly connected, and C follows from the chamber's
circulation condition ∮ d phi/dn ds = -2 A_chamber (n the chamber's outward normal, into the
silicone), which says that the warping displacement is single-valued around the chamber. Both
are the stationarity conditions of the complementary energy::

    Pi(phi, C) = 1/2 ∫ |∇phi|² dA - 2 ∫ phi dA - 2 C A_chamber

over phi = 0 on the outer circle and phi = C on the chamber (the chamber's boundary nodes are one
unknown, C), and then ``J = 2 ∫ phi dA + 2 C A_chamber``. Concentric check: phi = (r1² - r²)/2,
C = (r1² - r2²)/2 and J = pi (r1⁴ - r2⁴)/2, the polar moment.

The same J also comes from the warping function omega (∇² omega = 0, d omega/dn = z n_y - y n_z
on every boundary: the chamber is a free surface), ``J = I_p - ∫ |∇omega|² dA``. Finite elements
on the complementary energy (phi) bound J from below and on the potential energy (omega) from
above, up to the O(h⁴) error of the curved boundary (which shows only where the two agree to
about 1e-7 of J anyway, near the concentric section); the tests check both against the series
solution of :func:`series_torsion` (exact to round-off), the bracket on eccentric sections and
the convergence order (4, as P2's energy error).

The shear centre (Trefftz's definition, the centre of twist, independent of Poisson's ratio) is
the point (y_s, z_s) about which the warping function is orthogonal to y and z::

    ∫ (omega_c - z_s y + y_s z) y dA = 0,   ∫ (omega_c - z_s y + y_s z) z dA = 0

with omega_c the warping about the centroid and y, z centroidal; by symmetry z_s = 0.

Mesh: a structured grid in (s, t) in [0, 1] x [0, 2 pi) (the divisions around closer toward the
thin wall, t = tau + beta sin tau with beta = 1 - sqrt(thin wall / thick wall)) mapped by the blend
p(s, t) = (1 - s) (c + r2 e^{it}) + s r1 e^{it} (complex, p = y + r1 + i z about the disc's centre,
c = -d the chamber's centre) from the chamber's circle (s = 0) to the outer one (s = 1), whose
Jacobian (r1 - r2 + d cos t) ((1 - s) r2 + s r1) dt/dtau > 0 whenever r2 + d < r1.
Elements are quadratic (P2) and isoparametric (every node, edge mid-points included, placed by
the map), so the circles are curved to third order and J converges at the order of P2.

Composite stiffness (:func:`section_stiffness`)
-----------------------------------------------
Bending, by the modulus-weighted (transformed) section of the silicone (E) and the layer
(a rectangle of E_layer, ``layer_width`` across z and ``layer_thickness`` across y, its mid-plane
at y = -``layer_depth``, default 0 as in the paper, replacing the silicone where it lies)::

    EA      = E A + (E_layer - E) A_l
    y_N     = (E A y_c + (E_layer - E) A_l y_l) / EA          (the composite neutral axis)
    EI_bend = E (I_zz + A (y_c - y_N)²) + (E_layer - E) (w t³/12 + A_l (y_l - y_N)²)
    EI_side = E I_yy + (E_layer - E) t w³ / 12

The layer's in-plane bending, E_layer t w³/12, dominates EI_side (98 % at Table 1 with the default
width r1): the sideways stiffness goes with the cube of the width the paper does not give. Left
out of both: the fibres' axial share. Smeared, a helix of n fibres resists an axial strain with
n E_f A_f sin³ rho (5 N for the default fibre at rho = 10 deg), spread round the circle of r1:
taut, the two helices would add 2 n E_f A_f sin³ rho (r1²/2 + (r1 + y_N)²), about 15 % of EI_bend,
and 2 n E_f A_f sin³ rho r1²/2, 0.4 % of EI_side; slack, they carry no compression.

Torsion, three parts::

    GJ = G J + (G_layer - G) beta(w/t) w t³ + GJ_fibres

* the silicone, G = E / (2 (1 + nu)), nu = 0.5 (incompressible: G = E/3), J from phi above;
* the layer's own Saint-Venant torsion (a w x t rectangle, beta from the classical series,
  1/3 for a thin strip), G_layer = E_layer / (2 (1 + nu_layer)), nu_layer = 0.2 (Section 4.2).
  Assumed: the mesh adds no in-plane shear constraint on the silicone's warping (a woven mesh
  trellises freely in shear), so it acts as a strip of its own. A bonded isotropic strip (the
  paper's Abaqus idealisation) would also hold the silicone's warping along it: meshed as a
  region of G_layer inside the disc (w = r1 at the depth where it fits), that adds about as much
  again as the strip's own torsion at Table 1, some 20 % of the silicone's and layer's GJ;
* the fibres (a stated first-order model, in two states). A twist theta' shears the surface by
  gamma = r1 theta'; a fibre at angle rho from the hoop direction strains by
  eps_f = eps_a sin² rho + eps_h cos² rho ± gamma sin rho cos rho (axial and hoop strains of the
  surface; + for one helix of the double helix, - for the other). Smeared over the surface (many
  turns over the section's size), with n fibres per helix of modulus E_f and area A_f, each
  fibre having 1/sin rho of length per length of actuator:

  - ``fibres="slack"`` (the default; unpressurised, no pre-tension): Kevlar is inextensible in
    tension and slack in compression. One helix goes slack, the other keeps its length, which
    the incompressible silicone allows only by contracting: with a uniaxial contraction
    (eps_h = -eps_a / 2, the axial extension left free), eps_a (sin² rho - cos² rho / 2) =
    -gamma sin rho cos rho, whose strain energy 1/2 E A eps_a² per length gives::

        GJ_fibres = fibre_efficiency * E A r1² (sin rho cos rho / (sin² rho - cos² rho / 2))²

    zero for hoop windings (rho = 0), without bound toward the "magic" angle rho = 35.26 deg
    (tan² rho = 1/2), where a uniaxial contraction leaves the fibre's length unchanged and the
    fibres lock the twist: rho_deg within 1 deg of it is refused (unless fibre_efficiency = 0).
    Neglected: other ways for the silicone to contract (the chamber's collapse, which in
    series with this mode makes the true value lower: this is an upper estimate within the
    model) and the layer's restraint of the axial extension (which couples twist to bending);
  - ``fibres="taut"`` (pressurised: Eq. 16's tension holds both helices taut): both keep their
    length only if gamma = 0, so the twist stretches them, eps_f = ± gamma sin rho cos rho with
    eps_a = eps_h = 0, and::

        GJ_fibres = fibre_efficiency * 2 n E_f A_f r1² sin rho cos² rho

    valid while the twist's change of tension, E_f A_f gamma sin rho cos rho, stays below the
    pre-tension (Eq. 16: eta_r = 2 pi² r1 r2 P tan rho per fibre). E_f = 31067 MPa (Section 4.2);
    the fibre's diameter is not in the paper (0.2 mm assumed, a Kevlar thread) nor their number
    (n = 1 per helix: Eq. 16 balances 2N turns, one fibre each way);
  - ``fibres="none"``: zero.

  ``fibre_efficiency`` (default 1: the smeared model as derived) is the parameter a fit can adjust.

Every number the paper does not give is a named parameter of :func:`section_stiffness` with its
default and the reason for it (see there).

Examples
--------
>>> p = section_properties(8.0, 3.0, 4.0)
>>> round(p.area, 4), round(p.centroid[0], 4), p.centroid[1]
(172.7876, -7.3455, 0.0)
>>> round(p.torsion_constant, 1), round(p.shear_centre[1], 9)
(5084.4, 0.0)
>>> section_properties(8.0, 5.0, 4.0)
Traceback (most recent call last):
...
esba.model.section.SectionError: r2=5 with d=4, r1=8: the chamber must lie inside the actuator, r2 + d < r1
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from esba.infra import checks
from esba.infra.errors import InputError, RunError
from esba.infra.threads import blas_one_thread

__all__ = [
    "SectionError",
    "SectionProperties",
    "SectionStiffness",
    "section_properties",
    "section_stiffness",
    "exact_properties",
    "finite_elements",
    "series_torsion",
    "SeriesError",
    "SERIES_TERMS",
    "FESection",
    "rectangle_torsion_factor",
    "MESH_LEVELS",
    "DEFAULT_MESH",
    "LAYER_E",
    "LAYER_NU",
    "LAYER_THICKNESS",
    "SILICONE_NU",
    "MAGIC_ANGLE_DEG",
    "FIBRE_STATES",
    "fibre_torsion",
    "LOCK_WINDOW_DEG",
    "MIN_R1",
    "MAX_R1",
    "MAX_MODULUS",
    "FIBRE_ANGLE_DEG",
    "FIBRE_E",
    "FIBRE_DIAMETER",
    "FIBRES_PER_HELIX",
    "SECTION_PARAMETERS",
]

#: The inextensible layer's Young's modulus, MPa (Section 4.2, from Polygerinos et al., ref. [40]).
LAYER_E = 6500.0
#: The layer's Poisson's ratio (Section 4.2).
LAYER_NU = 0.2
#: The layer's thickness, mm: not in the paper. A woven nylon mesh is 0.2-0.4 mm thick; 0.3 mm.
LAYER_THICKNESS = 0.3
#: The silicone's Poisson's ratio: incompressible rubber (the paper's Eq. 9 conserves its volume).
SILICONE_NU = 0.5
#: The fibre angle from the hoop direction at which the fibre model locks the twist, degrees:
#: tan² rho = 1/2, where a uniaxial incompressible strain leaves the fibre's length unchanged.
MAGIC_ANGLE_DEG = math.degrees(math.atan(math.sqrt(0.5)))
#: Fibre angles this close to :data:`MAGIC_ANGLE_DEG` are refused (GJ_fibres would exceed 1000 times
#: the silicone's: the twist is locked, which a stiffness does not describe).
LOCK_WINDOW_DEG = 1.0
#: The Kevlar fibres' angle from the hoop direction, degrees (Table 1).
FIBRE_ANGLE_DEG = 10.0
#: The Kevlar fibres' Young's modulus, MPa (Section 4.2).
FIBRE_E = 31067.0
#: The fibres' diameter, mm: not in the paper; a Kevlar sewing thread, about 0.2 mm.
FIBRE_DIAMETER = 0.2
#: Fibres per helix: Eq. 16 balances the chamber's pressure with 2N turns, one fibre each way.
FIBRES_PER_HELIX = 1
#: The fibres' states (see the module): unpressurised, pressurised (pre-tensioned), left out.
FIBRE_STATES = ("slack", "taut", "none")

#: Every parameter of :func:`section_stiffness` beyond the scene's (r1, r2, d, E, rho): its
#: default, unit and source. ``layer_width`` None means r1.
SECTION_PARAMETERS: dict[str, tuple[Any, str, str]] = {
    "E_layer": (LAYER_E, "MPa", "Section 4.2"),
    "nu_layer": (LAYER_NU, "", "Section 4.2"),
    "layer_width": (None, "mm", "not in the paper: r1, a flat mesh half as wide as the actuator"),
    "layer_thickness": (LAYER_THICKNESS, "mm", "not in the paper: a woven nylon mesh, 0.2-0.4 mm"),
    "layer_depth": (0.0, "mm", "the paper's inextensible line (Eq. 6-8)"),
    "nu": (SILICONE_NU, "", "incompressible silicone (Eq. 9)"),
    "fibres": ("slack", "", "unpressurised; 'taut' when pressurised (Eq. 16's tension)"),
    "fibre_efficiency": (1.0, "", "the smeared fibre model as derived"),
    "E_fibre": (FIBRE_E, "MPa", "Section 4.2"),
    "fibre_diameter": (FIBRE_DIAMETER, "mm", "not in the paper: a Kevlar thread"),
    "fibres_per_helix": (FIBRES_PER_HELIX, "", "Eq. 16: one fibre each way"),
}

#: The external radii the section takes, mm (the second moments go with r1⁴ and stay finite doubles).
MIN_R1, MAX_R1 = 1e-6, 1e6

#: The largest modulus the composite takes, MPa (diamond's is about 1e6).
MAX_MODULUS = 1e9

#: Terms of :func:`series_torsion`: J to round-off down to walls of 0.5 mm at r1 = 8 (r2 = 1, d = 6.5).
SERIES_TERMS = 160

#: Mesh levels: (radial layers, divisions around). Level k doubles both of level k - 1.
MESH_LEVELS = {k: (3 * 2**k, 24 * 2**k) for k in range(0, 6)}
#: The default level: J within 1e-5 relative (its bracket by the warping function) at the Table 1 section, in about 0.1 s.
DEFAULT_MESH = 2


class SectionError(InputError):
    """A section parameter that is not allowed: the message names it, its value and what is allowed."""


class SeriesError(RunError):
    """The series solution did not converge with the terms given."""


@dataclass(frozen=True)
class SectionProperties:
    """The silicone section (disc r1 minus the chamber r2 offset by d), mm units.

    Attributes
    ----------
    area : float
        A, mm².
    centroid : tuple[float, float]
        (y_c, z_c), mm, in the base frame's (y, z) with the origin on the inextensible line
        (the disc's centre is at y = -r1).
    I_yy : float
        ∫ (z - z_c)² dA, mm⁴: about the centroidal axis parallel to y (the sideways bend).
    I_zz : float
        ∫ (y - y_c)² dA, mm⁴: about the centroidal axis parallel to z (the paper's in-plane bend).
    I_yz : float
        ∫ (y - y_c)(z - z_c) dA, mm⁴ (0: the section is symmetric about y).
    torsion_constant : float
        Saint-Venant's J, mm⁴, from Prandtl's stress function (finite elements, the chamber a hole
        with its circulation condition).
    shear_centre : tuple[float, float]
        (y_s, z_s), mm, Trefftz's shear centre (centre of twist), same frame as ``centroid``.
    torsion_upper : float
        J from the warping function on the same mesh, mm⁴: an upper bound (``torsion_constant``
        is a lower bound), up to the curved boundary's O(h⁴) error; their gap is the error
        estimate.
    mesh : int
        The mesh level used (:data:`MESH_LEVELS`).
    """

    area: float
    centroid: tuple[float, float]
    I_yy: float
    I_zz: float
    I_yz: float
    torsion_constant: float
    shear_centre: tuple[float, float]
    torsion_upper: float
    mesh: int

    @property
    def torsion_error(self) -> float:
        """The relative gap (torsion_upper - torsion_constant) / torsion_constant: the estimate of
        J's discretisation error (refine ``mesh`` when it matters)."""
        return (self.torsion_upper - self.torsion_constant) / self.torsion_constant

    @property
    def polar_moment(self) -> float:
        """I_p = I_yy + I_zz about the centroid, mm⁴."""
        return self.I_yy + self.I_zz


@dataclass(frozen=True)
class SectionStiffness:
    """The composite section's stiffnesses (silicone + layer + fibres), N·mm² (and N for EA).

    Attributes
    ----------
    EI_bend : float
        The paper's in-plane bend (curvature about z), about the composite neutral axis.
    EI_side : float
        The sideways bend (curvature about y), about the axis of symmetry z = 0.
    GJ : float
        Torsion: silicone + layer + fibres (the three parts below add up to it).
    GJ_silicone, GJ_layer, GJ_fibres : float
        The parts of GJ.
    EA : float
        Axial stiffness, N.
    neutral_axis : tuple[float, float]
        (y_N, z_N), mm: the modulus-weighted centroid, where the bending axes pass.
    section : SectionProperties
        The silicone section it was built on.
    parameters : tuple of (name, value)
        Every parameter it was built with, defaults resolved (``layer_width`` as a number).
    """

    EI_bend: float
    EI_side: float
    GJ: float
    GJ_silicone: float
    GJ_layer: float
    GJ_fibres: float
    EA: float
    neutral_axis: tuple[float, float]
    section: SectionProperties
    parameters: tuple[tuple[str, Any], ...] = ()

    def parameter(self, name: str) -> Any:
        """The value of a parameter of :data:`SECTION_PARAMETERS` (or rho_deg, mesh) this was built with."""
        return dict(self.parameters)[name]


# --- inputs -----------------------------------------------------------------------------------


def _positive(name: str, value: Any) -> float:
    v = checks.finite(name, value, SectionError)
    if v <= 0:
        raise SectionError(f"{name}={v:g}: expected a number > 0")
    return v


def _geometry(r1: Any, r2: Any, d: Any) -> tuple[float, float, float]:
    r1, r2 = _positive("r1", r1), _positive("r2", r2)
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


def _mesh_level(mesh: Any) -> int:
    return checks.whole("mesh", mesh, 0, SectionError, high=max(MESH_LEVELS), why="each level doubles the mesh both ways; level 5 takes minutes and resolves J to 1e-9")


# --- closed forms -----------------------------------------------------------------------------


def exact_properties(r1: float, r2: float, d: float) -> dict[str, float]:
    """Area, centroid and second moments of the section in closed form (see the module).

    >>> p = exact_properties(8.0, 3.0, 0.0)
    >>> round(p["I_yy"] - p["I_zz"], 12), round(p["y_c"], 12)
    (0.0, -8.0)
    """
    r1, r2, d = _geometry(r1, r2, d)
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


def rectangle_torsion_factor(aspect: float, terms: int = 50) -> float:
    """beta in J = beta w t³ of a w x t rectangle (w >= t), Saint-Venant's series.

    beta = 1/3 (1 - 192/pi^5 (t/w) sum_{k odd} tanh(k pi w / (2 t)) / k^5); 1/3 for a thin strip.

    >>> round(rectangle_torsion_factor(1.0), 4), round(rectangle_torsion_factor(1e6), 6)
    (0.1406, 0.333333)
    """
    a = max(aspect, 1.0 / aspect)
    s = sum(math.tanh(k * math.pi * a / 2) / k**5 for k in range(1, 2 * terms, 2))
    return (1 - 192 / math.pi**5 / a * s) / 3


# --- finite elements --------------------------------------------------------------------------


def _blend(r1: float, r2: float, d: float, s, t):
    """The map of (s, t) to (y, z): the chamber's circle at s = 0, the outer one at s = 1."""
    import numpy as np

    yc = -(r1 + d)  # the chamber's centre; the disc's centre is at -r1
    y = (1 - s) * (yc + r2 * np.cos(t)) + s * (-r1 + r1 * np.cos(t))
    z = (1 - s) * r2 * np.sin(t) + s * r1 * np.sin(t)
    return y, z


def _annulus_mesh(r1: float, r2: float, d: float, level: int):
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
    y, z = _blend(r1, r2, d, S.ravel(), T.ravel())
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
    ey, ez = _blend(r1, r2, d, s_mid, t_mid)
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


def finite_elements(r1: float, r2: float, d: float, *, mesh: int = DEFAULT_MESH) -> FESection:
    """The section by finite elements (P2, isoparametric) on mesh level ``mesh``; cached by its inputs.

    >>> fe = finite_elements(8.0, 3.0, 0.0, mesh=1)
    >>> round(fe.hole_constant, 3), round(fe.J_lower / (3.14159265358979 * (8**4 - 3**4) / 2), 5)
    (27.5, 1.0)
    """
    r1, r2, d = _geometry(r1, r2, d)
    return _finite_elements(r1, r2, d, _mesh_level(mesh))


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

    mesh, inner_f, outer_f = _annulus_mesh(r1, r2, d, level)
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


def series_torsion(r1: float, r2: float, d: float, *, terms: int = SERIES_TERMS) -> tuple[float, float]:
    """(J, C): the torsion constant and the chamber's stress-function value by a series, exact to
    round-off once converged (the cross-check of the finite elements; a few milliseconds).

    Prandtl's phi = -|w|²/2 + Re F(w) with w = y + r1 + i z (the disc's centre at 0, the chamber's
    at c = -d) and F = sum_k a_k (w/r1)^k + sum_k b_k (r2/(w - c))^k: analytic in the disc plus
    analytic outside the chamber, which spans every harmonic function of the annulus but the
    logarithm ln|w - c|, whose coefficient the chamber's circulation condition sets to zero. The
    real coefficients (the section is symmetric) and C are fitted by least squares to phi = 0 on
    the outer circle and phi = C on the chamber's; then J = 2 ∫phi dA + 2 C pi r2², with ∫phi dA
    by Green's identity (q = |w|²/4, ∇²q = 1) as integrals over the two circles, by the
    trapezoidal rule (spectrally accurate for these periodic integrands).

    Raises
    ------
    SeriesError
        When the series does not fit the boundary values to 1e-9 r1² (too few terms for a wall
        this thin): more ``terms`` are needed.

    Examples
    --------
    >>> J, C = series_torsion(8.0, 3.0, 0.0, terms=4)
    >>> round(float(J) / (math.pi * (8**4 - 3**4) / 2), 12), round(C, 9)
    (1.0, 27.5)
    """
    import numpy as np

    r1, r2, d = _geometry(r1, r2, d)
    K = checks.whole("terms", terms, 1, SectionError, high=1000, why="the fit's matrix grows as terms²")
    M = 4 * K + 16
    c = -d
    t = 2 * np.pi * np.arange(M) / M
    outer, inner = r1 * np.exp(1j * t), c + r2 * np.exp(1j * t)
    k = np.arange(K + 1)

    def columns(w):
        return (w[:, None] / r1) ** k[None, :], (r2 / (w[:, None] - c)) ** k[None, 1:]

    (ao, bo), (ai, bi) = columns(outer), columns(inner)
    G = np.vstack([np.hstack([ao.real, bo.real, np.zeros((M, 1))]), np.hstack([ai.real, bi.real, -np.ones((M, 1))])])
    rhs = np.concatenate([np.full(M, r1**2 / 2), np.abs(inner) ** 2 / 2])
    with blas_one_thread():  # a small dense problem: BLAS threads only wait on a busy machine
        coef = np.linalg.lstsq(G, rhs, rcond=None)[0]
    misfit = float(np.max(np.abs(G @ coef - rhs)))
    if not misfit < 1e-9 * r1**2:
        raise SeriesError(f"the series of {K} terms did not fit the boundary values (misfit {misfit:.2g} mm²): give more terms")
    a, b, C = coef[: K + 1], coef[K + 1 : -1], coef[-1]

    def dF(w):
        da = ((k[1:] / r1) * (w[:, None] / r1) ** (k[1:] - 1)) @ a[1:]
        db = (-(k[1:] / (w[:, None] - c)) * (r2 / (w[:, None] - c)) ** k[1:]) @ b
        return da + db

    def green(w, n, ds, phi):  # ∮ (phi dq/dn - q dphi/dn) ds
        dq = (w * np.conj(n)).real / 2
        dphi = -(w * np.conj(n)).real + (dF(w) * n).real
        return float(np.sum((phi * dq - np.abs(w) ** 2 / 4 * dphi) * ds))

    q_area = (math.pi * r1**4 / 2 - math.pi * r2**4 / 2 - math.pi * r2**2 * d**2) / 4  # ∫ q dA
    # n out of the silicone: outward on the outer circle, into the chamber on the inner one
    phi_area = green(outer, np.exp(1j * t), 2 * np.pi * r1 / M, 0.0) + green(inner, -np.exp(1j * t), 2 * np.pi * r2 / M, C) - 2 * q_area
    return float(2 * phi_area + 2 * C * math.pi * r2**2), float(C)


def section_properties(r1: float, r2: float, d: float, *, mesh: int = DEFAULT_MESH) -> SectionProperties:
    """The silicone section's properties (closed forms where exact, finite elements for J and the shear centre).

    Parameters
    ----------
    r1, r2, d : float
        External radius, chamber radius and eccentric distance, mm (r1, r2 > 0, d >= 0, r2 + d < r1).
    mesh : int
        Mesh level, 0 to 5 (:data:`MESH_LEVELS`); the default 2 (12 radial layers x 96 around,
        2304 quadratic triangles) takes about a tenth of a second and gives J to about 1e-5
        (``torsion_upper`` bounds it from above).

    Returns
    -------
    SectionProperties

    Raises
    ------
    SectionError
        A parameter that is not a finite number, not positive, or a chamber outside the disc.
    """
    r1, r2, d = _geometry(r1, r2, d)
    level = _mesh_level(mesh)
    ex = exact_properties(r1, r2, d)
    fe = _finite_elements(r1, r2, d, level)
    ys, zs = fe.shear_centre
    return SectionProperties(
        area=ex["area"],
        centroid=(ex["y_c"], ex["z_c"]),
        I_yy=ex["I_yy"],
        I_zz=ex["I_zz"],
        I_yz=ex["I_yz"],
        torsion_constant=fe.J_lower,
        shear_centre=(ys, 0.0),  # z_s = 0 by the symmetry (the mesh's own is round-off)
        torsion_upper=fe.J_upper,
        mesh=level,
    )


def _fibre_inputs(rho: float, state: Any, efficiency: Any, E_fibre: Any, diameter: Any, count: Any) -> dict[str, Any]:
    if state not in FIBRE_STATES:
        raise SectionError(f"fibres={checks.quote(state)}: allowed are {', '.join(FIBRE_STATES)}")
    eta = checks.finite("fibre_efficiency", efficiency, SectionError)
    if eta < 0:
        raise SectionError(f"fibre_efficiency={eta:g}: expected a number >= 0 (0: the fibres add nothing)")
    if state == "slack" and eta > 0 and abs(rho - MAGIC_ANGLE_DEG) < LOCK_WINDOW_DEG:
        raise SectionError(
            f"rho_deg={rho:g}: within {LOCK_WINDOW_DEG:g} deg of {MAGIC_ANGLE_DEG:.2f}, where the slack fibres lock the twist; "
            "expected another angle, fibres='taut' or fibre_efficiency=0"
        )
    E_f = _positive("E_fibre", E_fibre)
    if E_f > MAX_MODULUS:
        raise SectionError(f"E_fibre={E_f:g}: expected a modulus up to {MAX_MODULUS:g} MPa (a thousand times diamond's)")
    return {
        "rho_deg": rho,
        "state": state,
        "efficiency": eta,
        "E_fibre": E_f,
        "diameter": _positive("fibre_diameter", diameter),
        "count": checks.whole("fibres_per_helix", count, 1, SectionError, high=1000, why="fibres wound side by side on one helix"),
    }


def fibre_torsion(
    E: float,
    A: float,
    r1: float,
    *,
    rho_deg: float = FIBRE_ANGLE_DEG,
    state: str = "slack",
    efficiency: float = 1.0,
    E_fibre: float = FIBRE_E,
    diameter: float = FIBRE_DIAMETER,
    count: int = FIBRES_PER_HELIX,
) -> float:
    """What the double helix adds to GJ, N·mm² (the smeared model of the module, by ``state``).

    ``E`` and ``A`` are the silicone's modulus (MPa) and area (mm²), ``r1`` the winding radius;
    the inputs are taken as checked (:func:`section_stiffness` checks them).

    >>> round(fibre_torsion(0.54, 172.79, 8.0, rho_deg=0.0), 12), round(fibre_torsion(0.54, 172.79, 8.0, state="taut"))
    (0.0, 21039)
    """
    s, c = math.sin(math.radians(rho_deg)), math.cos(math.radians(rho_deg))
    if state == "none" or efficiency == 0:
        return 0.0
    if state == "taut":
        return efficiency * 2 * count * E_fibre * math.pi * diameter**2 / 4 * r1**2 * s * c * c
    return efficiency * E * A * r1**2 * (s * c / (s * s - c * c / 2)) ** 2


def section_stiffness(
    r1: float,
    r2: float,
    d: float,
    E: float,
    *,
    E_layer: float = LAYER_E,
    nu_layer: float = LAYER_NU,
    layer_width: float | None = None,
    layer_thickness: float = LAYER_THICKNESS,
    layer_depth: float = 0.0,
    nu: float = SILICONE_NU,
    rho_deg: float = FIBRE_ANGLE_DEG,
    fibres: str = "slack",
    fibre_efficiency: float = 1.0,
    E_fibre: float = FIBRE_E,
    fibre_diameter: float = FIBRE_DIAMETER,
    fibres_per_helix: int = FIBRES_PER_HELIX,
    mesh: int = DEFAULT_MESH,
) -> SectionStiffness:
    """The composite section's bending, torsion and axial stiffnesses (see the module for the formulas).

    Parameters
    ----------
    r1, r2, d : float
        The section, mm (Table 1: 8, 3, 4).
    E : float
        The silicone's Young's modulus, MPa (Section 4.2: 0.54).
    E_layer, nu_layer : float
        The inextensible layer's modulus, MPa, and Poisson's ratio (Section 4.2: 6500 and 0.2).
    layer_width : float or None
        The layer's width across z, mm. Not in the paper; default (None) ``r1``: a flat mesh half
        as wide as the actuator, well inside the round bottom.
    layer_thickness : float
        The layer's thickness across y, mm. Not in the paper; default 0.3 (a woven nylon mesh).
    layer_depth : float
        Depth of the layer's mid-plane from the paper's inextensible line y = 0 (the tangent at
        the disc's bottom) toward the chamber, mm, >= 0. Default 0: where the paper's model puts
        it (Eq. 6-8 bend the silicone about y = 0), so that ``EI_bend`` is E times the second
        moment of Eq. 8 plus the layer's own, E pi (5 r1⁴ - 4 r2² (r1 + d)² - r2⁴)/4 + ...
        (a flat strip at the tangent leaves the round disc at its edges: an idealisation the
        paper makes too; give the depth at which the strip fits, r1 - sqrt(r1² - w²/4) + t/2,
        for the other reading).
    nu : float
        The silicone's Poisson's ratio, 0 <= nu <= 0.5 (default 0.5, incompressible: G = E/3).
    rho_deg : float
        The fibres' angle from the hoop direction, degrees, 0 <= rho < 90 (Table 1: 10); with
        ``fibres="slack"`` not within 1 deg of the locking angle 35.26 deg.
    fibres : str
        The fibres' state (see the module): ``"slack"`` (default: unpressurised, the silicone
        accommodates the one taut helix), ``"taut"`` (pressurised: both helices pre-tensioned,
        their stretch resists), ``"none"``.
    fibre_efficiency : float
        Multiplies the fibres' torsional stiffness of the smeared model, >= 0 (default 1: the
        model as derived; 0: the fibres add nothing).
    E_fibre, fibre_diameter, fibres_per_helix
        The Kevlar's modulus, MPa (Section 4.2: 31067), the fibre's diameter, mm (not in the
        paper: 0.2), and the fibres per helix (1); used by ``fibres="taut"``.
    mesh : int
        Mesh level of the torsion constant (:func:`section_properties`).

    Returns
    -------
    SectionStiffness

    Examples
    --------
    Table 1 with E = 0.54 MPa: the layer's in-plane bending, E_layer t w³/12, makes 98 % of the
    sideways stiffness (it goes with the cube of ``layer_width``), while the in-plane EI is the
    paper's Eq. 8 plus the layer's own; the fibres nearly double the silicone's torsion:

    >>> k = section_stiffness(8.0, 3.0, 4.0, 0.54)
    >>> round(k.EI_bend), round(k.EI_side), round(0.54 * k.section.I_yy)
    (6540, 84896, 1703)
    >>> round(k.GJ), round(k.GJ_silicone), round(k.GJ_layer), round(k.GJ_fibres)
    (1950, 915, 190, 844)
    """
    r1, r2, d = _geometry(r1, r2, d)
    E = _positive("E", E)
    E_layer = _positive("E_layer", E_layer)
    if E_layer > MAX_MODULUS:
        raise SectionError(f"E_layer={E_layer:g}: expected a modulus up to {MAX_MODULUS:g} MPa (a thousand times diamond's)")
    if E_layer < E:
        raise SectionError(f"E_layer={E_layer:g} below E={E:g}: expected an inextensible layer stiffer than the silicone")
    t = _positive("layer_thickness", layer_thickness)
    w = r1 if layer_width is None else _positive("layer_width", layer_width)
    nu = checks.finite("nu", nu, SectionError)
    if not 0 <= nu <= 0.5:
        raise SectionError(f"nu={nu:g}: expected a Poisson's ratio from 0 to 0.5")
    nu_layer = checks.finite("nu_layer", nu_layer, SectionError)
    if not -1 < nu_layer <= 0.5:
        raise SectionError(f"nu_layer={nu_layer:g}: expected a Poisson's ratio above -1 and at most 0.5")
    rho = checks.finite("rho_deg", rho_deg, SectionError)
    if not 0 <= rho < 90:
        raise SectionError(f"rho_deg={rho:g}: expected a fibre angle from the hoop direction, 0 <= rho_deg < 90 degrees")
    if w / 2 >= r1:
        raise SectionError(f"layer_width={w:g}: expected a layer narrower than the actuator's diameter 2 r1 = {2 * r1:g}")
    depth = checks.finite("layer_depth", layer_depth, SectionError)
    if depth < 0:
        raise SectionError(f"layer_depth={depth:g}: expected a depth >= 0 mm from the inextensible line toward the chamber")
    chamber_low = r1 + d - r2  # the chamber's nearest point to the layer, depth below y = 0
    if depth + t / 2 >= chamber_low:
        raise SectionError(f"layer_depth={depth:g}: the layer reaches the chamber (at depth {chamber_low:g} mm); expected a shallower layer")

    fibre = _fibre_inputs(rho, fibres, fibre_efficiency, E_fibre, fibre_diameter, fibres_per_helix)
    p = section_properties(r1, r2, d, mesh=mesh)
    A, (yc, _zc) = p.area, p.centroid
    A_l, y_l = w * t, -depth
    dE = E_layer - E
    EA = E * A + dE * A_l
    yN = (E * A * yc + dE * A_l * y_l) / EA
    EI_bend = E * (p.I_zz + A * (yc - yN) ** 2) + dE * (w * t**3 / 12 + A_l * (y_l - yN) ** 2)
    EI_side = E * p.I_yy + dE * t * w**3 / 12
    G = E / (2 * (1 + nu))
    G_layer = E_layer / (2 * (1 + nu_layer))
    GJ_s = G * p.torsion_constant
    GJ_l = (G_layer - G) * rectangle_torsion_factor(w / t) * max(w, t) * min(w, t) ** 3
    GJ_f = fibre_torsion(E, A, r1, **fibre)
    return SectionStiffness(
        EI_bend=EI_bend,
        EI_side=EI_side,
        GJ=GJ_s + GJ_l + GJ_f,
        GJ_silicone=GJ_s,
        GJ_layer=GJ_l,
        GJ_fibres=GJ_f,
        EA=EA,
        neutral_axis=(yN, 0.0),
        section=p,
        parameters=(
            ("E_layer", E_layer),
            ("nu_layer", nu_layer),
            ("layer_width", w),
            ("layer_thickness", t),
            ("layer_depth", depth),
            ("nu", nu),
            ("rho_deg", rho),
            ("fibres", fibre["state"]),
            ("fibre_efficiency", fibre["efficiency"]),
            ("E_fibre", fibre["E_fibre"]),
            ("fibre_diameter", fibre["diameter"]),
            ("fibres_per_helix", fibre["count"]),
            ("mesh", p.mesh),
        ),
    )
