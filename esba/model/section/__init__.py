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
esba.model.section.geometry.SectionError: r2=5 with d=4, r1=8: the chamber must lie inside the actuator, r2 + d < r1
"""

from __future__ import annotations

from .fe import DEFAULT_MESH, MESH_LEVELS, FESection, finite_elements
from .geometry import MAX_R1, MIN_R1, SectionError, SeriesError, exact_properties
from .properties import SectionProperties, section_properties
from .series import SERIES_TERMS, series_torsion
from .stiffness import (
    FIBRE_ANGLE_DEG,
    FIBRE_DIAMETER,
    FIBRE_E,
    FIBRE_STATES,
    FIBRES_PER_HELIX,
    LAYER_E,
    LAYER_NU,
    LAYER_THICKNESS,
    LOCK_WINDOW_DEG,
    MAGIC_ANGLE_DEG,
    MAX_MODULUS,
    SECTION_FLAGS,
    SECTION_OUTPUTS,
    SECTION_PARAMETERS,
    SILICONE_NU,
    SectionStiffness,
    assumed_parameters,
    fibre_torsion,
    rectangle_torsion_factor,
    section_stiffness,
)

__all__ = [
    "SectionError",
    "SeriesError",
    "SectionProperties",
    "SectionStiffness",
    "FESection",
    "section_properties",
    "section_stiffness",
    "exact_properties",
    "finite_elements",
    "series_torsion",
    "fibre_torsion",
    "rectangle_torsion_factor",
    "SECTION_PARAMETERS",
    "SECTION_FLAGS",
    "SECTION_OUTPUTS",
    "assumed_parameters",
    "SERIES_TERMS",
    "MESH_LEVELS",
    "DEFAULT_MESH",
    "MIN_R1",
    "MAX_R1",
    "MAX_MODULUS",
    "LAYER_E",
    "LAYER_NU",
    "LAYER_THICKNESS",
    "SILICONE_NU",
    "FIBRE_ANGLE_DEG",
    "FIBRE_E",
    "FIBRE_DIAMETER",
    "FIBRES_PER_HELIX",
    "FIBRE_STATES",
    "MAGIC_ANGLE_DEG",
    "LOCK_WINDOW_DEG",
]
