"""esba: models of eccentric soft bending actuators, from derivation to design.

The runtime half of esba: it loads the CasADi models that ``derive`` generated (see
:mod:`esba.model`) and solves with them. Importing esba does no symbolic work, and no numerical
import either: ``Model``, ``load_model``, ``EffectSet`` and ``EffectError`` are loaded on first use
(so that ``esba --help`` starts without CasADi or NumPy); a missing model is generated on demand.
"""

from __future__ import annotations

from typing import Any

__all__ = ["EffectError", "EffectSet", "Model", "load_model"]
__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    if name in __all__:
        from . import model

        return getattr(model, name)
    raise AttributeError(f"module 'esba' has no attribute {name!r}")
