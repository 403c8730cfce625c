"""The composite section's stiffnesses: silicone, inextensible layer and fibres (see :mod:`esba.model.section`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from esba.infra import checks

from .fe import DEFAULT_MESH
from .geometry import SectionError, check_geometry, positive
from .properties import SectionProperties, section_properties

__all__ = [
    "LAYER_E", "LAYER_NU", "LAYER_THICKNESS", "SILICONE_NU", "MAGIC_ANGLE_DEG", "LOCK_WINDOW_DEG", "FIBRE_ANGLE_DEG", "FIBRE_E",
    "FIBRE_DIAMETER", "FIBRES_PER_HELIX", "FIBRE_STATES", "SECTION_PARAMETERS", "MAX_MODULUS", "SectionStiffness",
    "rectangle_torsion_factor", "fibre_torsion", "section_stiffness", "SECTION_OUTPUTS", "SECTION_FLAGS", "assumed_parameters",
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

#: The largest modulus the composite takes, MPa (diamond's is about 1e6).
MAX_MODULUS = 1e9


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


def rectangle_torsion_factor(aspect: float, terms: int = 50) -> float:
    """beta in J = beta w t³ of a w x t rectangle (w >= t), Saint-Venant's series.

    beta = 1/3 (1 - 192/pi^5 (t/w) sum_{k odd} tanh(k pi w / (2 t)) / k^5); 1/3 for a thin strip.

    >>> round(rectangle_torsion_factor(1.0), 4), round(rectangle_torsion_factor(1e6), 6)
    (0.1406, 0.333333)
    """
    a = max(aspect, 1.0 / aspect)
    s = sum(math.tanh(k * math.pi * a / 2) / k**5 for k in range(1, 2 * terms, 2))
    return (1 - 192 / math.pi**5 / a * s) / 3


def _modulus(name: str, value: Any) -> float:
    v = positive(name, value)
    if v > MAX_MODULUS:
        raise SectionError(f"{name}={v:g}: expected a modulus up to {MAX_MODULUS:g} MPa (a thousand times diamond's)")
    return v


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
    E_f = _modulus("E_fibre", E_fibre)
    return {
        "rho_deg": rho,
        "state": state,
        "efficiency": eta,
        "E_fibre": E_f,
        "diameter": positive("fibre_diameter", diameter),
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
    r1, r2, d = check_geometry(r1, r2, d)
    E = positive("E", E)
    E_layer = _modulus("E_layer", E_layer)
    if E_layer < E:
        raise SectionError(f"E_layer={E_layer:g} below E={E:g}: expected an inextensible layer stiffer than the silicone")
    t = positive("layer_thickness", layer_thickness)
    w = r1 if layer_width is None else positive("layer_width", layer_width)
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


#: The ``esba section`` flag of each of :data:`SECTION_PARAMETERS` (None: a keyword of
#: :func:`section_stiffness` only); a test checks them against the command's parser.
SECTION_FLAGS: dict[str, str | None] = {
    "E_layer": "--E-layer", "nu_layer": None, "layer_width": "--layer-width", "layer_thickness": "--layer-thickness",
    "layer_depth": "--layer-depth", "nu": "--nu", "fibres": "--fibres", "fibre_efficiency": "--fibre-efficiency",
    "E_fibre": "--E-fibre", "fibre_diameter": "--fibre-diameter", "fibres_per_helix": "--fibres-per-helix",
}

#: The section's outputs that the 3-D model takes (``esba fit`` fits these two directly); ``EI_bend``
#: is reported too (the planar terms keep the paper's Eq. 8).
SECTION_OUTPUTS = ("EI_side", "GJ")
_REPORTED = ("EI_bend", *SECTION_OUTPUTS)


def assumed_parameters(r1: float = 8.0, r2: float = 3.0, d: float = 4.0, E: float = 0.54, rho_deg: float = FIBRE_ANGLE_DEG,
                       mesh: int = 0) -> list[dict[str, Any]]:
    """Each parameter of :data:`SECTION_PARAMETERS`: its default (``layer_width`` resolved to r1),
    unit, source, and which of the section's outputs (``EI_bend`` and :data:`SECTION_OUTPUTS`) it moves,
    found by computing them (at Table 1's section by default) with the parameter changed: numbers by
    10 % (down for one at its upper bound, nu = 0.5; layer_depth, 0 by default, by 0.1 mm),
    ``fibres`` to each other state. The fibres' material (``E_fibre``, ``fibre_diameter``,
    ``fibres_per_helix``) enters only with ``fibres="taut"``, so it is changed in that state (``when``).

    >>> rows = {r["name"]: r for r in assumed_parameters()}
    >>> rows["layer_width"]["default"], rows["layer_width"]["moves"], rows["nu"]["moves"]
    (8.0, ('EI_bend', 'EI_side', 'GJ'), ('GJ',))
    >>> rows["E_fibre"]["moves"], rows["E_fibre"]["when"]
    (('GJ',), 'fibres = "taut"')
    """
    taut = ("E_fibre", "fibre_diameter", "fibres_per_helix")

    def outputs(**changes: Any) -> tuple[float, ...]:
        k = section_stiffness(r1, r2, d, E, rho_deg=rho_deg, mesh=mesh, **changes)
        return tuple(getattr(k, name) for name in _REPORTED)

    rows = []
    for name, (default, unit, source) in SECTION_PARAMETERS.items():
        value = r1 if name == "layer_width" and default is None else default
        base = {"fibres": "taut"} if name in taut else {}
        if name == "fibres":
            changed = [outputs(fibres=state) for state in FIBRE_STATES if state != value]
        elif name == "fibres_per_helix":
            changed = [outputs(**base, fibres_per_helix=value + 1)]
        elif name == "layer_depth":
            changed = [outputs(layer_depth=value + 0.1)]
        else:
            changed = [outputs(**base, **{name: value * (0.9 if name == "nu" else 1.1)})]
        before = outputs(**base)
        moves = tuple(out for j, out in enumerate(_REPORTED)
                      if any(abs(c[j] - before[j]) > 1e-12 * abs(before[j]) for c in changed))
        rows.append({"name": name, "flag": SECTION_FLAGS[name], "default": value, "unit": unit, "source": source, "moves": moves,
                     "when": 'fibres = "taut"' if name in taut else ""})
    return rows
