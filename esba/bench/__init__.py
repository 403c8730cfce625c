"""Benchmarks: medians over repeated runs, esba against the naive SciPy script and the compiled limit.

:mod:`.timing` (medians, the generation benchmark), :mod:`.solve`, :mod:`.path`,
:mod:`.scaling` and :mod:`.accuracy`. They return data; :mod:`esba.pages` writes it. May import
:mod:`esba.figures` and everything below it.
"""
