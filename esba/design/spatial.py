"""Designs that do not flip sideways: the fold constraint of :mod:`esba.design.envelope` plus
lateral-torsional buckling and twist over a cone of payload directions, in the 3-D model.

An envelope in space (:class:`SpatialEnvelope`) is a planar :class:`~esba.design.envelope.Envelope`
with a cone: every payload direction within ``cone_deg`` of one of the envelope's (in-plane)
directions, and a bound ``max_twist_deg`` on the total twist |sum(tau_i)|. A design must carry every
payload up to (1 + margin) max_payload in each such direction, at every pressure up to (1 + margin)
max_pressure, without losing stability sideways and without twisting past the bound. The samples
(stated, not a search): :data:`PRESSURES` pressures equally spaced in (0, pressure bound]; the
envelope's direction itself and, for a cone > 0, :data:`AZIMUTHS` directions on each of two
circles around it, tilted by half the cone and by the cone, at azimuths from 0 (tilted in the
plane, toward larger Omega) over 90 (out of the plane) to 180 (in the plane, toward smaller Omega);
the mirror image out of the plane (z -> -z) is the same load mirrored, so half of each circle is
enough.

At each sample the 3-D principal state (:func:`esba.analysis.maps3d.principal`: the payload raised
from 0 at the pressure) is followed up to twice the payload bound. Its constraint values:

* sideways: F_side / max_payload - (1 + margin), F_side the smallest load at which it loses
  stability over the samples (for an in-plane direction only a sideways loss counts: an in-plane
  fold is the fold constraint's, which finds it exactly in the (pressure, payload) plane);
* twist: 1 - twist / max_twist, the twist at the payload bound (where stable there).

The constraint of the design is the smallest of these and the planar fold constraint, so a cone of
0 with a section stiff enough never to buckle gives today's planar constraint, value for value.
:func:`optimise_envelope3d` runs :func:`esba.design.envelope.optimise_envelope` (map-based, PSO, or
both) on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from esba.infra import checks
from esba.model.scene import Payload, Scene

from .envelope import CLEAR_TOL, Envelope, FoldClearance, fold_clearance, optimise_envelope
from .problem import DesignError, DesignProblem

__all__ = ["SpatialEnvelope", "SidewaysClearance", "sideways_clearance", "optimise_envelope3d", "PRESSURES", "AZIMUTHS"]

#: Pressures sampled in (0, the pressure bound].
PRESSURES = 5
#: Directions sampled on the cone's rim (azimuths 0 to 180 degrees).
AZIMUTHS = 5


@dataclass(frozen=True)
class SpatialEnvelope:
    """A planar envelope, a cone of payload directions around each of its directions, and a twist bound.

    ``section``: EI_side and GJ (N mm^2) for every design; empty: each design's own eccentric
    section (:func:`esba.model.section.section_stiffness`, about half a second a new design).

    Examples
    --------
    >>> SpatialEnvelope(Envelope(0.3, 2.5), 20.0, 10.0).describe()
    'pressures 0 to 0.3 MPa, payloads 0 to 2.5 N at 90 deg, at s = 1, margin 10 %; directions within 20 deg of it; twist at most 10 deg; the eccentric section'
    >>> SpatialEnvelope(Envelope(0.3, 2.5), 95.0, 10.0)
    Traceback (most recent call last):
    ...
    esba.design.problem.DesignError: cone_deg=95: expected an angle from 0 to 90 degrees (--cone)
    """

    envelope: Envelope
    cone_deg: float = 0.0
    max_twist_deg: float = 10.0
    section: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.envelope, Envelope):
            raise DesignError(f"envelope={self.envelope!r}: expected an Envelope")
        c = checks.finite("cone_deg", self.cone_deg, DesignError)
        if not 0.0 <= c <= 90.0:
            raise DesignError(f"cone_deg={c:g}: expected an angle from 0 to 90 degrees (--cone)")
        t = checks.finite("max_twist_deg", self.max_twist_deg, DesignError)
        if not 0.0 < t < 180.0:
            raise DesignError(f"max_twist_deg={t:g}: expected an angle in (0, 180) degrees (--max-twist)")
        from esba.statics.spatial import SpatialError, check_section

        try:
            sec = check_section(self.section, complete=False)
        except SpatialError as exc:
            raise DesignError(str(exc)) from None
        if len(sec) == 1:
            raise DesignError(f"section: {', '.join(sec)} given alone; give both EI_side and GJ (N mm^2), or neither (each design's own section)")
        object.__setattr__(self, "section", dict(sec))
        object.__setattr__(self, "cone_deg", c)
        object.__setattr__(self, "max_twist_deg", t)

    def describe(self) -> str:
        sec = f"EI_side {self.section['EI_side']:g}, GJ {self.section['GJ']:g} N mm^2" if self.section else "the eccentric section"
        return f"{self.envelope.describe()}; directions within {self.cone_deg:g} deg of it; twist at most {self.max_twist_deg:g} deg; {sec}"

    def to_dict(self) -> dict[str, Any]:
        return {**self.envelope.to_dict(), "cone_deg": self.cone_deg, "max_twist_deg": self.max_twist_deg,
                "section_nmm2": dict(self.section) or "each design's eccentric section"}

    def directions(self) -> list[tuple[float, float, float]]:
        """The sampled directions: (envelope direction Omega_0 deg, tilt deg, azimuth deg) -> see :func:`_direction`."""
        out = []
        for om in self.envelope.directions_deg:
            out.append((om, 0.0, 0.0))
            if self.cone_deg > 0:
                for tilt in (0.5 * self.cone_deg, self.cone_deg):
                    out += [(om, tilt, float(a)) for a in np.linspace(0.0, 180.0, AZIMUTHS)]
        return out

    def pressures(self) -> np.ndarray:
        return np.linspace(0.0, self.envelope.pressure_bound, PRESSURES + 1)[1:]


def _direction(omega_deg: float, tilt_deg: float, azimuth_deg: float) -> tuple[float, float]:
    """(Omega, Beta) in degrees of the direction tilted by ``tilt`` from (Omega_0, Beta = 0), toward
    azimuth ``azimuth`` (0: in the plane toward larger Omega, 90: out of the plane toward +z)."""
    om, t, a = (math.radians(v) for v in (omega_deg, tilt_deg, azimuth_deg))
    d0 = np.array([math.cos(om), -math.sin(om), 0.0])
    e_in = np.array([-math.sin(om), -math.cos(om), 0.0])  # d d0 / d Omega
    e_out = np.array([0.0, 0.0, 1.0])
    d = math.cos(t) * d0 + math.sin(t) * (math.cos(a) * e_in + math.sin(a) * e_out)
    beta = math.degrees(math.asin(max(-1.0, min(1.0, float(d[2])))))
    omega = math.degrees(math.atan2(-float(d[1]), float(d[0])))
    if abs(d[2]) < 1e-15:
        beta = 0.0
    return omega, beta


@dataclass(frozen=True)
class SidewaysClearance:
    """The constraint of design (r2, d) in space: the planar fold constraint (``planar``), the smallest
    sideways-loss payload over the samples (``sideways_payload``, N; inf: none up to twice the
    payload bound), the largest twist at the payload bound (``twist_deg``), each's value, and
    ``value``, the smallest of the three (>= 0: clear). ``nearest``: the limiting sample and what
    limits it; ``inside``: it snaps, flips or twists past the bound inside the envelope itself."""

    r2: float
    d: float
    planar: FoldClearance
    sideways_payload: float
    sideways_value: float
    twist_deg: float
    twist_value: float
    value: float
    inside: bool
    nearest: dict[str, Any] | None
    section: dict[str, float]

    @property
    def clear(self) -> bool:
        return self.value >= -CLEAR_TOL

    @property
    def fold_payload(self) -> float:
        return self.planar.fold_payload

    def to_dict(self) -> dict[str, Any]:
        def num(v):
            return v if math.isfinite(v) else None

        return {
            "r2_mm": self.r2, "d_mm": self.d, "value": num(self.value), "clear": self.clear, "snaps_inside": self.inside,
            "nearest_fold": self.nearest, "planar": self.planar.to_dict(),
            "sideways_payload_n": num(self.sideways_payload), "sideways_value": num(self.sideways_value),
            "twist_deg": self.twist_deg, "twist_value": self.twist_value, "section_nmm2": self.section,
        }


def _section(problem: DesignProblem, spatial: SpatialEnvelope, r2: float, d: float) -> dict[str, float]:
    if spatial.section:
        return dict(spatial.section)
    from esba.model.section import section_stiffness

    a = problem.actuator
    k = section_stiffness(a.r1, r2, d, a.E, rho_deg=a.rho_deg)
    return {"EI_side": k.EI_side, "GJ": k.GJ}


def sideways_clearance(problem: DesignProblem, spatial: SpatialEnvelope, r2: float, d: float) -> SidewaysClearance:
    """The constraint of design (r2, d) in space (see the module)."""
    from esba.analysis.maps3d import Plane3D, principal, twist_of

    env = spatial.envelope
    planar = fold_clearance(problem, env, r2, d)
    section = _section(problem, spatial, r2, d)
    base = problem.scene(r2, d, pressure=0.0, loaded=False)
    top = 2.0 * env.payload_bound
    best_f, best_t = math.inf, 0.0
    where_f: dict[str, Any] | None = None
    where_t: dict[str, Any] | None = None
    inside = planar.inside
    for om0, tilt, az in spatial.directions():
        omega, beta = _direction(om0, tilt, az)
        scene = Scene(base.actuator, pressure=0.0, payloads=(Payload(env.max_payload, omega, env.at, beta),), segments=problem.segments, variant=problem.variant)
        plane = Plane3D.from_scene(scene, "pressure", "payload", section, spatial.max_twist_deg)
        for p in spatial.pressures():
            vals = plane.values(float(p), env.max_payload)
            try:
                out = principal(plane, vals, top, (env.payload_bound, env.max_payload))
            except RuntimeError as exc:
                raise DesignError(f"design r2 = {r2:g}, d = {d:g} mm: the 3-D state was lost at P = {p:g} MPa, Omega = {omega:g}, Beta = {beta:g} deg ({exc})") from None
            counts = math.isfinite(out.critical) and (beta != 0.0 or out.lost_sideways())
            sample = {"direction_deg": om0, "omega_deg": omega, "beta_deg": beta, "pressure_mpa": float(p)}
            if counts and out.critical < best_f:
                best_f = out.critical
                where_f = {**sample, "payload_n": out.critical, "kind": ("sideways " if out.lost_sideways() else "") + out.kind.replace(" (not located)", "")}
            if counts and out.critical <= env.max_payload and p <= env.max_pressure:
                inside = True
            if env.payload_bound in out.states:
                tw = math.degrees(twist_of(plane.model, out.states[env.payload_bound]))
                if tw > best_t:
                    best_t, where_t = tw, {**sample, "payload_n": env.payload_bound, "kind": f"twist {tw:.3f} deg"}
                if p <= env.max_pressure and env.max_payload in out.states and math.degrees(twist_of(plane.model, out.states[env.max_payload])) > spatial.max_twist_deg:
                    inside = True
    side_value = best_f / env.max_payload - (1.0 + env.margin) if math.isfinite(best_f) else math.inf
    twist_value = 1.0 - best_t / spatial.max_twist_deg
    value = min(planar.value, side_value, twist_value)
    if value == planar.value:
        nearest = planar.nearest
    elif value == side_value:
        nearest = where_f
    else:
        nearest = where_t
    return SidewaysClearance(float(r2), float(d), planar, best_f, side_value, best_t, twist_value, value, bool(inside), nearest, section)


def optimise_envelope3d(problem: DesignProblem | None, spatial: SpatialEnvelope, method: str = "map", options=None, pso_options=None):
    """The stiffest design clear of folds, of lateral-torsional buckling and of twist beyond the bound
    over the cone (:func:`esba.design.envelope.optimise_envelope` on :func:`sideways_clearance`)."""
    if not isinstance(spatial, SpatialEnvelope):
        raise DesignError(f"spatial={spatial!r}: expected a SpatialEnvelope")
    return optimise_envelope(problem, spatial.envelope, method, options, pso_options,
                             clearance=lambda pr, env, r2, d: sideways_clearance(pr, spatial, r2, d))


# ---------------------------------------------------------------------------------------------
# docs/design.md: do today's designs survive an off-plane load?

#: The operating envelope of docs/maps.md's design plane (esba.pages.maps.ENVELOPE; a test checks they agree).
SNAP_FREE_ENVELOPE = Envelope(0.3, 2.5, (90.0,), 1.0, 0.05)
#: The cone of the page's check, degrees, and the twist bound.
PAGE_CONE_DEG = 30.0
PAGE_MAX_TWIST_DEG = 10.0
#: A section stiff out of the plane (docs/3d.md: the Table 1 actuator stays in its plane to 4 N).
STIFF_SECTION = {"EI_side": 4e5, "GJ": 1e5}


@dataclass(frozen=True, eq=False)
class OffPlaneCheck:
    """Designs checked against an off-plane load of the envelope's size: per design (name, r2, d, K)
    and per section (name -> SidewaysClearance)."""

    spatial: dict[str, SpatialEnvelope]
    designs: list[tuple[str, float, float, float]]
    results: dict[tuple[str, str], SidewaysClearance]


def off_plane_check(progress=None) -> OffPlaneCheck:
    """The paper's optimum (IPOPT, the stiffness problem) and today's snap-free design (the map-based
    optimum of :data:`SNAP_FREE_ENVELOPE`, as docs/maps.md finds it) against payloads of the envelope's
    size within :data:`PAGE_CONE_DEG` of its direction, with each design's eccentric section and with
    :data:`STIFF_SECTION` (tens of seconds)."""
    from .optimise import optimise_ipopt

    say = progress or (lambda msg: None)
    say("3-D: the paper's optimum")
    paper = optimise_ipopt(DesignProblem())
    say("3-D: today's snap-free design")
    free = optimise_envelope(None, SNAP_FREE_ENVELOPE, "map")
    designs = [("the paper's optimum", paper.r2_mm, paper.d_mm, paper.stiffness_n_per_m),
               ("today's snap-free design", free.r2_mm, free.d_mm, free.stiffness_n_per_m)]
    spatial = {"eccentric": SpatialEnvelope(SNAP_FREE_ENVELOPE, PAGE_CONE_DEG, PAGE_MAX_TWIST_DEG),
               "stiff": SpatialEnvelope(SNAP_FREE_ENVELOPE, PAGE_CONE_DEG, PAGE_MAX_TWIST_DEG, STIFF_SECTION)}
    problem = DesignProblem().replace(max_pressure=SNAP_FREE_ENVELOPE.max_pressure)
    results = {}
    for name, r2, d, _ in designs:
        for key, sp in spatial.items():
            say(f"3-D: {name}, {key} section")
            results[(name, key)] = sideways_clearance(problem, sp, r2, d)
    return OffPlaneCheck(spatial, designs, results)


__all__ += ["OffPlaneCheck", "off_plane_check", "SNAP_FREE_ENVELOPE", "STIFF_SECTION", "PAGE_CONE_DEG", "PAGE_MAX_TWIST_DEG"]
