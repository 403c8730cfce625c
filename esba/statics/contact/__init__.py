"""Equilibria with contact: frictionless obstacles as inequality constraints, forces as multipliers.

:mod:`.nlp` (the constrained NLP on IPOPT), :mod:`.equilibrium` (:func:`solve_contact`: the
contacts, the KKT check, a prescribed tip displacement), :mod:`.sweeps` (the blocked-force curve,
a finger closing on a cylinder, a tester's displacement path, with their contact events).
May import :mod:`esba.paths` and everything below it.
"""

from .equilibrium import (
    Contact,
    ContactEquilibrium,
    ContactOptions,
    ContactOptionsError,
    ContactState,
    Displacement,
    KKT,
    solve_contact,
)

__all__ = ["Contact", "ContactEquilibrium", "ContactOptions", "ContactOptionsError", "ContactState", "Displacement", "KKT", "solve_contact"]
