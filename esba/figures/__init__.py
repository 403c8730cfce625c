"""Figures: matplotlib drawings of what the computations return (no pyplot state).

:mod:`.scenes` (shapes), :mod:`.paths`, :mod:`.sweeps`, :mod:`.design`, :mod:`.fit` and
:mod:`.paper` (the paper's figures, a registry). May import :mod:`esba.studies` and everything
below it.
"""
