"""esba: models of eccentric soft bending actuators, from derivation to design.

The runtime half of esba: it loads the CasADi models that ``derive`` generated (see
:mod:`esba.model`) and solves with them. Importing esba does no symbolic work; a missing model
is generated on demand.
"""

from .model import EffectError, EffectSet, Model, load_model

__all__ = ["EffectError", "EffectSet", "Model", "load_model"]
__version__ = "0.1.0"
