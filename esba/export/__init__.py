"""Export a model as dependency-free C: the equilibrium, the pressure for a target angle and the
tip's stiffness on a microcontroller, with no Python, no CasADi and no allocation.

:mod:`.ccode` builds the C source (CasADi's code generator for the model's functions, the solver
from the templates in ``templates/``), :mod:`.writer` writes an export's folder (header, source,
``Makefile``, README, demo), :mod:`.reference` computes what Python's ``solve()`` gives for a
parameter vector (the README's example line), :mod:`.build` compiles and measures exported code
with the system's compilers, and :mod:`.binding` calls a compiled export from Python (tests and
benchmarks). May import :mod:`esba.statics` and everything below it (not :mod:`esba.analysis`,
which stands on the same floor).
"""
