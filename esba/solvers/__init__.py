"""Numerical solvers on a generated model: IPOPT, the compiled Newton kernels, the swarm, the NLP builder.

:mod:`.minimise` (IPOPT, the minimiser of record), :mod:`.newton` (Newton steps and ramps as
CasADi Functions, O(n) from the Hessian's structure), :mod:`.pso` (particle swarm) and
:mod:`.eqnlp` (equilibrium-constrained NLPs for design and calibration), :mod:`.roots` (Brent's
method, without importing scipy.optimize). May import
:mod:`esba.model` and :mod:`esba.infra`.
"""
