"""The vocabulary shared by the derivation and the runtime: effects, variants, model names.

Pure Python (no SymPy import), so that ``esba`` can name and validate models without any
symbolic work.

An *effect* is one term of the total potential energy, Eq. (3) and (19) of the paper:

=========  ==============================================  =====================
effect     energy term                                     parameters it needs
=========  ==============================================  =====================
air        compressed air, -P dV (Eq. 5)                    P
axial      axial rubber strain energy U_a (Eq. 6-8)          E
radial     radial rubber strain energy U_r (Eq. 9-13)        E
fibres     fibre restraint psi_fbrs (Eq. 16-18)             P, rho
payload    a point force anywhere on the actuator (Eq. 14)   F_k, Omega_k, s_k
gravity    the weight of every segment at its mid-point      M, g
           (Eq. 15)
=========  ==============================================  =====================

``payload`` may appear with a count (``payload:2``): each payload has its own magnitude,
direction and point of application. The geometry ``L, r1, r2, d`` is always an input: the
kinematics and the model's domain need it.

Examples
--------
>>> e = EffectSet.parse("air,axial,radial,fibres,payload:2")
>>> e.tag
'air_axial_radial_fibres_payload2'
>>> e.parameters()
('L', 'r1', 'r2', 'd', 'rho', 'E', 'P', 'F1', 'Omega1', 's1', 'F2', 'Omega2', 's2')
>>> model_filename(3, e, "paper")
'm_n003__air_axial_radial_fibres_payload2__paper.py'
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: The energy terms, in canonical order (payload and gravity last, as in Eq. 19).
EFFECTS: tuple[str, ...] = ("air", "axial", "radial", "fibres", "payload", "gravity")

#: The default effect set: the paper's Table 2 case (no gravity, Section 4.1).
DEFAULT_EFFECTS = "air,axial,radial,fibres,payload"

#: ``paper``: the model whose numbers the paper reports (Eq. 13 derived from its own integrand,
#: Eq. 16 on the projected chamber width 2 r2). ``printed``: every equation exactly as printed.
VARIANTS: tuple[str, ...] = ("paper", "printed")
DEFAULT_VARIANT = "paper"

#: The largest payload count a model may carry (a guard against typos such as ``payload:100``).
MAX_PAYLOADS = 16

#: Unit of every parameter (mm, N, MPa; angles in radians inside the models).
UNITS: dict[str, str] = {
    "theta": "rad",
    "L": "mm",
    "r1": "mm",
    "r2": "mm",
    "d": "mm",
    "rho": "rad",
    "E": "MPa",
    "P": "MPa",
    "F": "N",
    "Omega": "rad",
    "s": "1 (fraction of L from the base)",
    "M": "kg",
    "g": "m/s^2 (so that M*g is in N)",
}


class EffectError(ValueError):
    """An effect list, variant or segment count that esba does not know."""


@dataclass(frozen=True)
class EffectSet:
    """Which energy terms a model contains.

    Parameters
    ----------
    air, axial, radial, fibres, gravity : bool
        Whether the term is present.
    payloads : int
        Number of point payloads (0 to ``MAX_PAYLOADS``).
    """

    air: bool = True
    axial: bool = True
    radial: bool = True
    fibres: bool = True
    payloads: int = 1
    gravity: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.payloads, int) or isinstance(self.payloads, bool):
            raise EffectError(f"payloads={self.payloads!r}: expected an integer from 0 to {MAX_PAYLOADS}")
        if not 0 <= self.payloads <= MAX_PAYLOADS:
            raise EffectError(f"payloads={self.payloads}: expected an integer from 0 to {MAX_PAYLOADS}")
        if not self.names():
            raise EffectError("the effect set is empty: name at least one of " + ", ".join(EFFECTS))

    @classmethod
    def parse(cls, text: str | list[str] | tuple[str, ...]) -> EffectSet:
        """Parse ``"air,axial,payload:2"`` (or a list of such tokens).

        ``payload`` may be repeated or given a count, ``payload:K`` or ``payloadK``.
        """
        tokens = text.split(",") if isinstance(text, str) else list(text)
        flags = {name: False for name in EFFECTS}
        payloads = 0
        for raw in tokens:
            token = str(raw).strip().lower()
            if not token:
                continue
            m = re.fullmatch(r"payloads?(?::|\*)?(\d+)?", token)
            if m:
                count = int(m.group(1)) if m.group(1) is not None else 1
                if count < 1:
                    raise EffectError(f"effect {raw!r}: a payload count must be at least 1")
                payloads += count
                continue
            if token == "fibers":
                token = "fibres"
            if token not in flags:
                raise EffectError(
                    f"unknown effect {raw!r}: allowed are {', '.join(EFFECTS)} (payload may take a count, e.g. payload:2)"
                )
            flags[token] = True
        flags.pop("payload")
        return cls(payloads=payloads, **flags)

    def names(self) -> tuple[str, ...]:
        """The effects present, in canonical order (``payload`` once, whatever the count)."""
        out = [e for e in ("air", "axial", "radial", "fibres") if getattr(self, e)]
        if self.payloads:
            out.append("payload")
        if self.gravity:
            out.append("gravity")
        return tuple(out)

    @property
    def tag(self) -> str:
        """A canonical, file-name-safe name of the set."""
        parts = [e for e in ("air", "axial", "radial", "fibres") if getattr(self, e)]
        if self.payloads:
            parts.append(f"payload{self.payloads}")
        if self.gravity:
            parts.append("gravity")
        return "_".join(parts)

    def spec(self) -> str:
        """The set as a string that :meth:`parse` reads back."""
        parts = [e for e in ("air", "axial", "radial", "fibres") if getattr(self, e)]
        if self.payloads:
            parts.append("payload" if self.payloads == 1 else f"payload:{self.payloads}")
        if self.gravity:
            parts.append("gravity")
        return ",".join(parts)

    def parameters(self) -> tuple[str, ...]:
        """Names of the model's parameter inputs (besides ``theta``), in canonical order."""
        names = ["L", "r1", "r2", "d"]
        if self.fibres:
            names.append("rho")
        if self.axial or self.radial:
            names.append("E")
        if self.air or self.fibres:
            names.append("P")
        for k in range(1, self.payloads + 1):
            names += [f"F{k}", f"Omega{k}", f"s{k}"]
        if self.gravity:
            names += ["M", "g"]
        return tuple(names)

    def terms(self) -> tuple[str, ...]:
        """Names of the energy terms the model reports, in the order of its ``terms`` output."""
        out = [e for e in ("air", "axial", "radial", "fibres") if getattr(self, e)]
        out += [f"payload{k}" for k in range(1, self.payloads + 1)]
        if self.gravity:
            out.append("gravity")
        return tuple(out)


def check_segments(n: object) -> int:
    """Return ``n`` as an int if it is a whole number >= 1, else raise :class:`EffectError`."""
    if isinstance(n, bool) or not isinstance(n, (int,)) and not (isinstance(n, float) and n.is_integer()):
        if isinstance(n, str) and re.fullmatch(r"\s*\d+\s*", n):
            n = int(n)
        else:
            raise EffectError(f"segments={n!r}: expected a whole number >= 1")
    n = int(n)  # type: ignore[arg-type]
    if n < 1:
        raise EffectError(f"segments={n}: expected a whole number >= 1")
    return n


def check_variant(variant: str) -> str:
    """Return ``variant`` if known, else raise :class:`EffectError`."""
    if variant not in VARIANTS:
        raise EffectError(f"unknown variant {variant!r}: allowed are {', '.join(VARIANTS)}")
    return variant


def model_filename(n: int, effects: EffectSet, variant: str) -> str:
    """File name of the generated model for ``(n, effects, variant)``."""
    return f"m_n{check_segments(n):03d}__{effects.tag}__{check_variant(variant)}.py"
