"""Where a model came from: the hash of the derivation source (pure Python, no SymPy).

A model file is reproducible from ``derive/*.py``; the SHA-256 over those files (in name order)
identifies the derivation that produced it. ``esba`` uses it to key its cache of models generated
on demand, so that a changed derivation never serves a stale model.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path

DERIVE_DIR = Path(__file__).resolve().parent
#: The folder of committed models (the package ``generated``).
GENERATED_DIR = DERIVE_DIR.parent / "generated"


#: The modules whose text decides a generated model's bytes (the audit, for one, does not).
GENERATION_SOURCES = (
    "effects.py",
    "emit.py",
    "energy.py",
    "kinematics.py",
    "paper.py",
    "program.py",
    "provenance.py",
    "smooth.py",
    "symbols.py",
)


@lru_cache(maxsize=1)
def source_hash() -> str:
    """SHA-256 over the derivation source that generation uses, in name order."""
    h = hashlib.sha256()
    for path in (DERIVE_DIR / name for name in GENERATION_SOURCES):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()
