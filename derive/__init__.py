"""Symbolic derivation of the ESBA model (SymPy).

This package is the mathematics of the paper (Yang et al., *Kinematics and Statics of Eccentric
Soft Bending Actuators with External Payloads*), derived from first principles and audited against
the printed equations. It emits CasADi model files into ``generated/``; the runtime package
``esba`` loads those and never needs SymPy unless a model is missing.

Modules
-------
symbols      every symbol with its unit
effects      the vocabulary of effects and variants (pure Python, no SymPy)
smooth       sinc-type functions that are exact in value, gradient and Hessian at 0
kinematics   twists, hat map, exponentials, the POE map (Eq. 1-2) and the chain structure
energy       each energy term of Eq. 3 derived from its integrand or definition (Eq. 5-18)
paper        the paper's printed closed forms, transcribed verbatim
audit        derived versus printed, with verdicts, and the docs page
program      the energy, gradient and Hessian of an n-segment model as a straight-line program
emit         SymPy -> CasADi source code, the manifest, the ``generated/`` folder
effects3d    the vocabulary of the spatial (3-D) family (pure Python): effects, parameters, its hash
spatial      Eq. (1)-(2) on SE(3): each joint bends in plane, sideways and twists; the segment template
program3d    the spatial model's energy, gradient and Hessian as a straight-line program (screw form)
emit3d       the spatial family into ``generated/m3d_*.py`` and ``generated/manifest3d.json``
"""
