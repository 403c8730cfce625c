"""Design optimisation of the chamber (r2, d): problems, the batched evaluator, the NLP, IPOPT and PSO.

:mod:`.problem`, :mod:`.evaluate`, :mod:`.nlp`, :mod:`.optimise`, and :mod:`.cases` (the design
cases of ``docs/design.md``, as data). May import :mod:`esba.analysis` and everything below it
(not :mod:`esba.calibration`, its neighbour on the same floor).
"""
