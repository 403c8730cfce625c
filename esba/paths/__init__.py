"""The continuation engine: path following, and what it finds on a branch.

One entry, the algorithm a value (as BifurcationKit's ``continuation(prob, alg, opts)``):
``continuation(problem, theta0, lam0, to=..., algorithm=Natural() | PALC())`` returns a
:class:`~esba.paths.branch.Branch` either way, judged by one acceptance rule
(:class:`esba.solvers.newton.Acceptance`). :mod:`.problem` (g(theta, lambda) = 0 with the
parameters affine in lambda), :mod:`.corrector` (Newton on the bordered system, on the compiled
O(n) kernel), :mod:`.locate` (folds and branch points, located), :mod:`.branch` (the result: a
Branch and its special points), :mod:`.continuation` (the engine, PALC's trace and branch
switching) and :mod:`.loading` (quasi-static load histories: natural first, pseudo-arclength
through folds, jumps where the stable branch ends) and :mod:`.extended` (curves of an extended
system in two parameters, such as fold curves, with the zeros of their test functions located). :func:`esba.statics.equilibrium.solve`, the
batch, the design evaluator and the stiffness all stand on it. May import :mod:`esba.solvers`,
:mod:`esba.model` and :mod:`esba.infra`.
"""
