"""The vocabulary of the spatial (3-D) model family: effects, parameters, file names.

Pure Python (no SymPy import), like :mod:`derive.effects`, so that ``esba`` names and validates
3-D models without symbolic work.

Each joint of the spatial virtual robot carries three rotations: the paper's in-plane bend
``theta`` (about the layer's normal z), a sideways bend ``psi`` (about y, the paper's bending
direction) and a twist ``tau`` (about the tangent x). Two energy terms are always present:

=========  ==================================================  ================
effect     energy term                                         parameters
=========  ==================================================  ================
side       sideways bending, 1/2 EI_side (n/L) psi_i^2          EI_side
twist      torsion, 1/2 GJ (n/L) tau_i^2                        GJ
=========  ==================================================  ================

and the rest is chosen as in the planar family, plus two new ones:

=========  ==================================================  ======================
air, axial, radial, fibres   the paper's in-plane terms, verbatim   as planar
rod        a plain elastic rod in the plane,                     EI, kappa0
           1/2 EI (n/L) (theta_i - kappa0 L/n)^2
payload    a point force in any direction at fraction s of L      F_k, Omega_k, Beta_k, s_k
moment     a point moment (body components) at fraction s         mx_k, my_k, mz_k, sm_k
couple     a couple of dead forces on a rigid arm e fixed to the   cx_k, cy_k, cz_k,
           section at fraction s: moment m at the straight state  ax_k, ay_k, az_k, sc_k
gravity    the weight of each segment at its mid-point,          M, gx, gy, gz
           in any direction
=========  ==================================================  ======================

The two moments differ away from the plane. ``moment`` is a generalised force on the joint
rotations, potential -m . sum_i sigma_i (tau_i, psi_i, theta_i): exact for a moment about the layer's
normal z in the bending plane (it rolls a rod up into a full circle, B2), and the body moment only to
first order in the sideways bend and twist. ``couple`` is a physical load at any rotation: the forces
+f at P(s) + R(s) e and -f at P(s), f = (m x e) / |e|^2 fixed in space, e (perpendicular to m) turning
with the section, potential -f . (R(s) e - e); its moment is m at the straight state and turns with
the arm (a couple about z bending the actuator by theta is m cos theta). It loads the stiffness as
real couples do, so the twist buckling of a cantilever under an end torque (Greenhill's problem) is a
branch point of its Hessian.

Payload direction: ``f = F (cos(Beta) cos(Omega), -cos(Beta) sin(Omega), sin(Beta))``; Beta = 0 is
the planar payload of Eq. (14) (Omega from the vertical x toward -y), Beta turns it out of the
plane toward +z.

Examples
--------
>>> e = Effects3D.parse("rod,payload,moment")
>>> e.tag
'rod_side_twist_payload1_moment1'
>>> e.parameters()
('L', 'EI_side', 'GJ', 'EI', 'kappa0', 'F1', 'Omega1', 'Beta1', 's1', 'mx1', 'my1', 'mz1', 'sm1')
>>> model3d_filename(3, Effects3D.parse("air,axial,radial,fibres,payload"), "paper")
'm3d_n003__air_axial_radial_fibres_side_twist_payload1__paper.py'
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from functools import lru_cache

from .effects import MAX_PAYLOADS, EffectError, EffectSet, check_segments, check_variant
from .provenance import DERIVE_DIR, GENERATION_SOURCES

MANIFEST_3D = "manifest3d.json"
#: The format of the spatial model files.
FORMAT_3D = 1
#: The spatial derivation's own modules (the planar ones it builds on are in GENERATION_SOURCES).
SOURCES_3D = ("effects3d.py", "emit3d.py", "program3d.py", "spatial.py")

#: The terms of the spatial family, in canonical order.
EFFECTS_3D: tuple[str, ...] = ("air", "axial", "radial", "fibres", "rod", "side", "twist", "payload", "moment", "couple", "gravity")

#: The default spatial effect set: the paper's Table 2 case with the sideways and twist terms.
DEFAULT_EFFECTS_3D = "air,axial,radial,fibres,payload"

#: The plain elastic rod with one tip payload.
ROD_EFFECTS = "rod,payload"

#: Unknowns per joint, in the order of the model's unknown vector q = [theta; psi; tau].
COORDINATES: tuple[str, ...] = ("theta", "psi", "tau")

UNITS_3D: dict[str, str] = {
    "EI_side": "N*mm^2",
    "GJ": "N*mm^2",
    "EI": "N*mm^2",
    "kappa0": "1/mm",
    "Beta": "rad",
    "mx": "N*mm",
    "my": "N*mm",
    "mz": "N*mm",
    "sm": "1 (fraction of L from the base)",
    "cx": "N*mm",
    "cy": "N*mm",
    "cz": "N*mm",
    "ax": "1 (a direction in the section's axes)",
    "ay": "1 (a direction in the section's axes)",
    "az": "1 (a direction in the section's axes)",
    "sc": "1 (fraction of L from the base)",
    "gx": "m/s^2",
    "gy": "m/s^2",
    "gz": "m/s^2",
}


@dataclass(frozen=True)
class Effects3D:
    """Which terms a spatial model contains (``side`` and ``twist`` always)."""

    air: bool = True
    axial: bool = True
    radial: bool = True
    fibres: bool = True
    rod: bool = False
    payloads: int = 1
    moments: int = 0
    gravity: bool = False
    couples: int = 0

    def __post_init__(self) -> None:
        for name, value in (("payloads", self.payloads), ("moments", self.moments), ("couples", self.couples)):
            if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= MAX_PAYLOADS:
                raise EffectError(f"{name}={value!r}: expected an integer from 0 to {MAX_PAYLOADS}")

    @classmethod
    def parse(cls, text: str | list[str] | tuple[str, ...]) -> Effects3D:
        """Parse ``"air,axial,payload:2,moment"``; ``side`` and ``twist`` may be named (always present)."""
        tokens = text.split(",") if isinstance(text, str) else list(text)
        flags = {name: False for name in ("air", "axial", "radial", "fibres", "rod", "gravity")}
        counts = {"payload": 0, "moment": 0, "couple": 0}
        for raw in tokens:
            token = str(raw).strip().lower()
            if not token or token in ("side", "twist"):
                continue
            m = re.fullmatch(r"(payload|moment|couple)s?(?::|\*)?(\d+)?", token)
            if m:
                count = int(m.group(2)) if m.group(2) is not None else 1
                if count < 1:
                    raise EffectError(f"effect {raw!r}: a count must be at least 1")
                counts[m.group(1)] += count
                continue
            token = "fibres" if token == "fibers" else token
            if token not in flags:
                raise EffectError(
                    f"unknown effect {raw!r}: allowed in 3-D are {', '.join(EFFECTS_3D)} (payload, moment and couple may take a count, e.g. payload:2)"
                )
            flags[token] = True
        return cls(payloads=counts["payload"], moments=counts["moment"], couples=counts["couple"], **flags)

    @classmethod
    def from_planar(cls, planar: EffectSet) -> Effects3D:
        """The spatial set whose restriction to the plane is the planar set ``planar``."""
        return cls(planar.air, planar.axial, planar.radial, planar.fibres, False, planar.payloads, 0, planar.gravity)

    def planar(self) -> EffectSet | None:
        """The planar set this restricts to, or None when it has terms the planar family lacks."""
        if self.rod or self.moments or self.couples:
            return None
        return EffectSet(self.air, self.axial, self.radial, self.fibres, self.payloads, self.gravity)

    def in_plane(self) -> tuple[str, ...]:
        """The in-plane terms that depend on theta alone (the paper's, or the rod's)."""
        return tuple(e for e in ("air", "axial", "radial", "fibres", "rod") if getattr(self, e))

    def names(self) -> tuple[str, ...]:
        out = [*self.in_plane(), "side", "twist"]
        out += ["payload"] * bool(self.payloads) + ["moment"] * bool(self.moments) + ["couple"] * bool(self.couples)
        out += ["gravity"] * self.gravity
        return tuple(out)

    @property
    def tag(self) -> str:
        parts = [*self.in_plane(), "side", "twist"]
        if self.payloads:
            parts.append(f"payload{self.payloads}")
        if self.moments:
            parts.append(f"moment{self.moments}")
        if self.couples:
            parts.append(f"couple{self.couples}")
        if self.gravity:
            parts.append("gravity")
        return "_".join(parts)

    def spec(self) -> str:
        parts = list(self.in_plane())
        for name, count in (("payload", self.payloads), ("moment", self.moments), ("couple", self.couples)):
            if count:
                parts.append(name if count == 1 else f"{name}:{count}")
        if self.gravity:
            parts.append("gravity")
        return ",".join(parts) if parts else "side,twist"

    def parameters(self) -> tuple[str, ...]:
        """Names of the parameter inputs (besides q), in canonical order."""
        names = ["L"]
        if self.air or self.axial or self.radial or self.fibres:
            names += ["r1", "r2", "d"]
        if self.fibres:
            names.append("rho")
        if self.axial or self.radial:
            names.append("E")
        if self.air or self.fibres:
            names.append("P")
        names += ["EI_side", "GJ"]
        if self.rod:
            names += ["EI", "kappa0"]
        for k in range(1, self.payloads + 1):
            names += [f"F{k}", f"Omega{k}", f"Beta{k}", f"s{k}"]
        for k in range(1, self.moments + 1):
            names += [f"mx{k}", f"my{k}", f"mz{k}", f"sm{k}"]
        for k in range(1, self.couples + 1):
            names += [f"cx{k}", f"cy{k}", f"cz{k}", f"ax{k}", f"ay{k}", f"az{k}", f"sc{k}"]
        if self.gravity:
            names += ["M", "gx", "gy", "gz"]
        return tuple(names)

    def terms(self) -> tuple[str, ...]:
        out = [*self.in_plane(), "side", "twist"]
        out += [f"payload{k}" for k in range(1, self.payloads + 1)]
        out += [f"moment{k}" for k in range(1, self.moments + 1)]
        out += [f"couple{k}" for k in range(1, self.couples + 1)]
        if self.gravity:
            out.append("gravity")
        return tuple(out)


def model3d_filename(n: int, effects: Effects3D, variant: str) -> str:
    """File name of the generated spatial model for ``(n, effects, variant)``."""
    return f"m3d_n{check_segments(n):03d}__{effects.tag}__{check_variant(variant)}.py"


@lru_cache(maxsize=1)
def source_hash_3d() -> str:
    """SHA-256 over the planar generation sources and the spatial ones, in name order: a change to
    either marks the spatial models stale, while the planar models' own hash stays as it is."""
    h = hashlib.sha256()
    for name in sorted(set(GENERATION_SOURCES) | set(SOURCES_3D)):
        path = DERIVE_DIR / name
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()
