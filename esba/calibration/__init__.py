"""How far to trust the model: measurements, fits, uncertain parameters and their propagation.

:mod:`.measurements` (measurement files), :mod:`.fit` (parameters with covariance),
:mod:`.sigmas` and :mod:`.uncertainty` (first order and Monte Carlo in this process),
:mod:`.experiments` (the paper's EXP and FEM values) and :mod:`.validation` (Table 2). May import
:mod:`esba.analysis` and everything below it (not :mod:`esba.design`, its neighbour).
"""
