"""Statics: equilibria of scenes, one at a time along its load history or many at once on the compiled batch.

:mod:`.equilibrium` (:func:`~esba.statics.equilibrium.solve`, certified by IPOPT), :mod:`.history`
(the load histories a solve can follow), :mod:`.equilibria` (every equilibrium of a scene by deflated
Newton, and solve()'s multistability check), :mod:`.batch`
(arrays of scenes), :mod:`.batch_options` and :mod:`.compiled` (the batch's settings and its C),
:mod:`.text` (the text ``esba solve`` and ``esba equilibria`` print, and the results' ``summary()``),
:mod:`.contact` (equilibria with obstacles: contact forces as multipliers, KKT checks, paths with contact).
May import :mod:`esba.paths` and everything below it.
"""
