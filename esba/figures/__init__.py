"""Figures: matplotlib drawings of what the computations return (no pyplot state, save a
result's ``plot()`` without axes, which asks pyplot for a figure that a notebook shows).

:mod:`.scenes` (shapes), :mod:`.paths`, :mod:`.sweeps`, :mod:`.design`, :mod:`.fit`,
:mod:`.paper` (the paper's figures, a registry) and :mod:`.results` (each result's ``plot(ax)``). Every drawing function returns its
``matplotlib.figure.Figure`` (or takes the data it draws), so that what a figure shows can be
checked without reading a PNG; :func:`.scenes.save_figure` writes one. May import
:mod:`esba.studies` and everything below it (never :mod:`esba.pages`).
"""
