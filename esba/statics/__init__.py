"""Statics: equilibria of scenes, one at a time along its load history or many at once on the compiled batch.

:mod:`.equilibrium` (:func:`~esba.statics.equilibrium.solve`, certified by IPOPT), :mod:`.batch`
(arrays of scenes), :mod:`.batch_options` and :mod:`.compiled` (the batch's settings and its C).
May import :mod:`esba.paths` and everything below it.
"""
