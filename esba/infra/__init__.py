"""Infrastructure, the bottom floor: what every other package stands on and nothing of the physics.

The per-user cache (:mod:`.cache`, :mod:`.fncache`), where commands write (:mod:`.outputs`), the files
users give, read bounded and only when regular (:mod:`.inputs`), the
terminal (:mod:`.console`), JSON without NaN (:mod:`.jsonsafe`), one BLAS thread (:mod:`.threads`),
Ctrl-C (:mod:`.interrupts`), value checks (:mod:`.checks`), round-off printed without its noise digits
(:mod:`.roundoff`), the example files shipped in the package (:mod:`.examples`), the error hierarchy
(:mod:`.errors`) and how a result shows itself in Python and in a notebook (:mod:`.report`: short
repr, ``summary()``, ``plot()``, rich display). Imports nothing of esba's (only ``esba.__version__``).
"""
