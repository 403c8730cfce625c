"""Studies: many solves planned as one run, chunked, streamed to a file, resumable, on Dask or here.

:mod:`.sweep` (grids), :mod:`.sweep_runner` (a grid chunk by chunk), :mod:`.monte_carlo` (samples
chunk by chunk), :mod:`.chunks` (the study file) and :mod:`.distributed` (where chunks run). May
import :mod:`esba.design`, :mod:`esba.calibration` and everything below them.
"""
