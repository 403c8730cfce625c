"""The silicone section's properties: closed forms where exact, finite elements for J and the shear centre."""

from __future__ import annotations

from dataclasses import dataclass

from .fe import DEFAULT_MESH, check_mesh, finite_elements
from .geometry import check_geometry, exact_properties

__all__ = ["SectionProperties", "section_properties"]

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
    r1, r2, d = check_geometry(r1, r2, d)
    level = check_mesh(mesh)
    ex = exact_properties(r1, r2, d)
    fe = finite_elements(r1, r2, d, mesh=level)
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
