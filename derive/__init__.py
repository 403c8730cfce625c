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
"""
