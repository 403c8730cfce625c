"""What a solved scene tells: stiffness, the pressure for a target, sensitivities, its paths.

:mod:`.stiffness`, :mod:`.sensitivity`, :mod:`.path_analysis` (a scene's branch in one
parameter, the branches crossing it and its hysteresis) and :mod:`.path_cases` (the path cases
of ``docs/paths.md``). May import :mod:`esba.statics` and everything below it.
"""
