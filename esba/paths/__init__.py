"""Path following: the continuation engine and what it finds on a branch.

:mod:`.problem` (g(theta, lambda) = 0 with the parameters affine in lambda), :mod:`.corrector`
(Newton on the bordered system), :mod:`.locate` (folds and branch points, located),
:mod:`.branch` (the result: a Branch and its special points), :mod:`.continuation` (the trace and
branch switching) and :mod:`.loading` (quasi-static load histories: jumps at folds). May import
:mod:`esba.solvers`, :mod:`esba.model` and :mod:`esba.infra`.
"""
