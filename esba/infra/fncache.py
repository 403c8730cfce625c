"""Built CasADi Functions kept in esba's cache in CasADi's own serialisation.

Executing a generated model file builds its SX graphs in Python: about 2 s at n = 100. CasADi can
serialise a built Function and read it back (``StringSerializer`` / ``StringDeserializer``) in a
few tens of milliseconds, so the first load of a model saves its Functions, and later processes
read them. The serialisation is text that zlib shrinks about eightfold (n = 8: 580 kB to 68 kB),
for a millisecond of decompression per 500 kB, so the files are kept compressed. The file's name holds a key: the SHA-256 of what the Functions were built from (the
model file's bytes, and for Functions esba derives from a model the source of the module that
derives them), CasADi's version and this module's format, so that a changed model, a changed
builder or another CasADi never reads a stale file. Files go through :mod:`esba.infra.cache` (atomic,
a checksum checked before anything is deserialised: a truncated file is discarded and rebuilt,
never handed to CasADi); a cache that cannot be written only costs the speed.

Examples
--------
>>> import casadi as ca
>>> x = ca.SX.sym("x")
>>> build = lambda: {"f": ca.Function("f", [x], [x**2])}
>>> first = cached("doctest", ["example"], build)
>>> again = cached("doctest", ["example"], lambda: 1 / 0)   # read back: the builder is not called
>>> float(again["f"](3.0))
9.0
"""

from __future__ import annotations

import hashlib
import logging
import zlib
from pathlib import Path
from typing import Callable, Mapping, Sequence

import casadi as ca

from . import cache

__all__ = ["cached", "key_of_files", "FORMAT"]

#: The layout of the serialised files (bump when it changes): 2, zlib-compressed.
FORMAT = 2

_log = logging.getLogger("esba.infra.fncache")


def key_of_files(*paths: Path | str) -> str:
    """The SHA-256 (hex) of the bytes of ``paths``, in order: what a build depends on."""
    h = hashlib.sha256()
    for p in paths:
        h.update(Path(p).read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def _path(tag: str, parts: Sequence[str]) -> Path:
    h = hashlib.sha256()
    for part in (*parts, ca.__version__, str(FORMAT)):
        h.update(str(part).encode())
        h.update(b"\0")
    return cache.root() / "functions" / f"{tag}_{h.hexdigest()[:24]}.casadi"


def _read(path: Path) -> dict[str, ca.Function] | None:
    data, why = cache.read_verified(path)
    if why is not None:
        _log.warning("cached functions %s are damaged (%s): building them again", path, why)
        cache.discard(path)
        return None
    try:
        reader = ca.StringDeserializer(zlib.decompress(data).decode("ascii"))
        count = int(reader.unpack())
        names = [str(reader.unpack()) for _ in range(count)]
        return {name: reader.unpack() for name in names}
    except (RuntimeError, ValueError, OSError, UnicodeDecodeError, zlib.error) as exc:
        _log.warning("cached functions %s cannot be read (%s): building them again", path, exc.__class__.__name__)
        cache.discard(path)
        return None


def _write(path: Path, functions: Mapping[str, ca.Function]) -> None:
    writer = ca.StringSerializer()
    writer.pack(len(functions))
    for name in functions:
        writer.pack(name)
    for fun in functions.values():
        writer.pack(fun)
    try:
        cache.usable_root(path.parent)
        cache.write_bytes(path, zlib.compress(writer.encode().encode("ascii"), 6))
    except (OSError, cache.CacheError) as exc:  # a read-only cache costs speed, not correctness
        _log.debug("cannot keep %s in the cache: %s", path, exc)


def cached(tag: str, key_parts: Sequence[str], build: Callable[[], Mapping[str, ca.Function]]) -> dict[str, ca.Function]:
    """The Functions ``build()`` returns, read from the cache when they were kept under the same key.

    Parameters
    ----------
    tag : str
        A readable prefix of the file name (e.g. the model file's stem).
    key_parts : sequence of str
        Everything the build depends on (hashes of files, settings); CasADi's version is added.
    build : callable
        Builds the Functions (a dict name -> Function) when the cache has none.
    """
    path = _path(tag, key_parts)
    if path.exists():
        found = _read(path)
        if found is not None:
            return found
    built = dict(build())
    _write(path, built)
    return built
