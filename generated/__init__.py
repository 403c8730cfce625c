"""Generated CasADi models of the ESBA: DO NOT MODIFY BY HAND.

Every ``m_n*.py`` file here is written by ``derive/emit.py``; ``manifest.json`` records what
produced each one. Refresh them all with ``esba generate --refresh``.
"""
