"""esba: models of eccentric soft bending actuators, from derivation to design.

The runtime half of esba: it loads the CasADi models that ``derive`` generated
(:mod:`esba.model`) and solves with them. The names below are the front door, loaded on first
use, so that ``import esba`` (and ``esba --help``) imports neither NumPy nor CasADi:

>>> from esba import Scene, Payload, solve
>>> r = solve(Scene(pressure=0.1, payloads=(Payload(1.0),)))
>>> r.ok, round(r.total_angle_deg, 2)
(True, 36.63)

The packages, from the bottom up (each imports only from those below it; see
``docs/architecture.md``): :mod:`esba.infra`, :mod:`esba.model`, :mod:`esba.solvers`,
:mod:`esba.paths`, :mod:`esba.statics`, :mod:`esba.analysis` and :mod:`esba.export` (a model as
dependency-free C), :mod:`esba.design` and
:mod:`esba.calibration`, :mod:`esba.studies`, :mod:`esba.figures`, :mod:`esba.bench`,
:mod:`esba.pages`, :mod:`esba.cli`.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: The lazy façade: name -> the module that defines it.
_FACADE = {
    # errors
    "EsbaError": "esba.infra.errors",
    "InputError": "esba.infra.errors",
    "RunError": "esba.infra.errors",
    "EquilibriumError": "esba.infra.errors",
    # the model
    "Model": "esba.model.generated",
    "load_model": "esba.model.generated",
    "EffectSet": "esba.model.generated",
    "EffectError": "esba.model.generated",
    "Scene": "esba.model.scene",
    "Payload": "esba.model.scene",
    "Actuator": "esba.model.scene",
    "load_scene": "esba.model.scene",
    "SceneError": "esba.model.scene",
    "pressure_for_angle": "esba.model.closed_form",
    # paths
    "PathProblem": "esba.paths.problem",
    "PathOptions": "esba.paths.continuation",
    "trace": "esba.paths.continuation",
    "Branch": "esba.paths.branch",
    "history": "esba.paths.loading",
    # solving
    "SolverOptions": "esba.statics.equilibrium",
    "Equilibrium": "esba.statics.equilibrium",
    "solve": "esba.statics.equilibrium",
    "BatchOptions": "esba.statics.batch",
    "solve_scenes": "esba.statics.batch",
    "equilibria": "esba.statics.equilibria",
    "EquilibriaOptions": "esba.statics.equilibria",
    # analyses
    "secant_stiffness": "esba.analysis.stiffness",
    "tangent_stiffness": "esba.analysis.stiffness",
    "pressure_for_target": "esba.analysis.stiffness",
    "sensitivities": "esba.analysis.sensitivity",
    "DesignProblem": "esba.design.problem",
    "optimise": "esba.design.optimise",
    "fit": "esba.calibration.fit",
    "load_measurements": "esba.calibration.measurements",
    "propagate": "esba.calibration.uncertainty",
    "estimate_load": "esba.calibration.sensing",
    "Pose": "esba.calibration.sensing",
    "Measured": "esba.calibration.sensing",
    "parse_sigma": "esba.calibration.sigmas",
    "ellipse": "esba.calibration.uncertainty",
    "Ellipse": "esba.calibration.uncertainty",
    "Plane": "esba.analysis.folds",
    "stability_map": "esba.analysis.maps",
    # studies
    "sweep": "esba.studies.sweep",
    "plan_sweep": "esba.studies.sweep",
}

__all__ = sorted(_FACADE)


def __getattr__(name: str) -> Any:
    module = _FACADE.get(name)
    if module is None:
        raise AttributeError(f"module 'esba' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_FACADE))
