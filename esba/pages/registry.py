"""Every docs page, by name: the one list that ``esba docs`` and each page's own command use.

The list is plain data (no NumPy, no CasADi: ``esba --help`` reads it); :func:`page` imports a
page's module when it is asked for.

Examples
--------
>>> list(ENTRIES)
['derivations', 'validation', 'design', 'paths', 'experiments', 'sensing', 'accuracy-vs-time', 'performance', 'scaling', 'equilibria', 'maps', 'contact', '3d']
>>> [e.name for e in ENTRIES.values() if e.slow]
['accuracy-vs-time', 'performance', 'scaling', '3d']
>>> check_names(["paths", "paths", "validation"])
['paths', 'validation']
>>> check_names(["path"])  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.pages.registry.PageError: unknown page 'path': allowed are derivations, validation, design, paths, ...
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Sequence

from esba.infra.errors import InputError

__all__ = ["Entry", "ENTRIES", "PageError", "page", "check_names"]


class PageError(InputError):
    """A page name that is not in the registry: the message lists the allowed names."""


@dataclass(frozen=True)
class Entry:
    """One page: its name, its file in ``docs/``, the module that defines it, the command that
    writes it, whether it is a benchmark that takes minutes, and what it shows."""

    name: str
    file: str
    module: str
    command: str
    slow: bool
    about: str


ENTRIES: dict[str, Entry] = {
    e.name: e
    for e in (
        Entry("derivations", "derivations.md", "esba.pages.derivations", "esba audit", False,
              "the paper's printed equations against the derivation"),
        Entry("validation", "validation.md", "esba.pages.validation", "esba validate", False,
              "Table 2 against the model"),
        Entry("design", "design.md", "esba.pages.design", "esba design --write-doc docs/design.md", False,
              "the stiffest chamber by IPOPT and PSO, the constrained designs"),
        Entry("paths", "paths.md", "esba.pages.paths", "esba path --write-doc docs/paths.md", False,
              "folds, hysteresis and buckling of the Table 1 actuator"),
        Entry("experiments", "experiments.md", "esba.pages.experiments", "esba experiments --write-doc docs/experiments.md", False,
              "the paper's EXP and FEM values, fits, cross-validation"),
        Entry("sensing", "sensing.md", "esba.pages.sensing", "esba docs --write sensing", False,
              "the payload from the shape: errors by measurement, the blind region, Table 3 read back"),
        Entry("accuracy-vs-time", "accuracy-vs-time.md", "esba.pages.accuracy", "esba bench accuracy", True,
              "error against n, tolerance, effects, naive scripts, the batch"),
        Entry("performance", "performance.md", "esba.pages.performance",
              "esba bench generation|solve|path|maps|contact --markdown docs/performance.md", True,
              "generation, single calls, path tracing"),
        Entry("scaling", "scaling.md", "esba.pages.scaling", "esba bench scaling --markdown docs/scaling.md", True,
              "sweeps in this process and on Dask workers"),
        Entry("equilibria", "equilibria.md", "esba.pages.equilibria", "esba docs --write equilibria", False,
              "every equilibrium of the bistable window and the detached branch, barriers"),
        Entry("maps", "maps.md", "esba.pages.maps", "esba map --write-doc docs/maps.md", False,
              "stability maps: fold curves, cusps, regions by stable states, designs clear of folds"),
        Entry("contact", "contact.md", "esba.pages.contact", "esba docs --write contact", False,
              "contact: the blocked-force curve, a tester through the snap, a finger closing on a cylinder, KKT checks"),
        Entry("3d", "3d.md", "esba.pages.spatial", "esba docs --write 3d", True,
              "the actuator in 3-D: the planar restriction, rod benchmarks B1-B5, the sideways flip, the cost"),
    )
}


def check_names(names: Sequence[str] | None) -> list[str]:
    """``names`` without repeats, in the order given (None or empty: every page), each checked."""
    if not names:
        return list(ENTRIES)
    for name in names:
        if name not in ENTRIES:
            raise PageError(f"unknown page {name!r}: allowed are {', '.join(ENTRIES)}")
    return list(dict.fromkeys(names))


def page(name: str) -> Any:
    """The :class:`esba.pages.page.Page` called ``name`` (its module imported now; the registry
    itself imports no page, so that the protocol may read the registry)."""
    (name,) = check_names([name])
    return importlib.import_module(ENTRIES[name].module).PAGE
