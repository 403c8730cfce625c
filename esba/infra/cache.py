"""esba's per-user cache: files written atomically with a checksum, checked before they are used.

The cache holds what esba makes on demand: model files (Python source that is executed) and
compiled batch solvers (shared libraries that are loaded). Executing a truncated model file or
loading a truncated library can do anything from a confusing traceback to killing the process
(a truncated ``.so`` ends in a bus error). So every file goes through one mechanism:

* :func:`write_bytes` / :func:`write_text` / :func:`install` first write a small record beside
  the file (``NAME.sha256``: the SHA-256 and the size), then the file itself, each atomically
  (a temporary file renamed into place), both readable by others (0644) so that a shared cache
  works. Writers of the same content agree, so racing processes are harmless.
* :func:`damage` says why a file may not be trusted (missing record, wrong size, wrong hash, a
  folder in its place) before it is executed or loaded; :func:`discard` removes it and its
  record, and the caller makes it again.
* :func:`usable_root` checks the cache folder itself (``$ESBA_CACHE_DIR``, else
  ``$XDG_CACHE_HOME/esba``, else ``~/.cache/esba``) before anything is generated into it, and
  raises :class:`CacheError` with one line naming the variable and the path.
* The cache is bounded: after each write, when its files add up to more than
  ``$ESBA_CACHE_MAX`` (default 1G; ``K``/``M``/``G`` suffixes, ``0`` for no bound) the least
  recently used files are removed until it holds at most 80 % of that (:func:`prune`; a file is
  "used" when it is read and verified). Everything in it is made again on demand, so a removed
  file costs only the time to make it. :func:`usage` counts the files by kind (``esba cache``).

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> p = write_text(d / "m.py", "x = 1\\n")
>>> damage(p) is None, oct(p.stat().st_mode & 0o777)
(True, '0o644')
>>> _ = p.write_text("x = ")            # truncated behind esba's back
>>> damage(p)
'truncated or changed: 4 bytes, 6 expected'
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from .errors import InputError

__all__ = [
    "CacheError", "root", "usable_root", "write_bytes", "write_text", "install", "damage", "discard", "record_path",
    "KINDS", "CacheFile", "files", "usage", "prune", "clear", "limit", "parse_size", "DEFAULT_LIMIT",
]

#: Permissions of every file esba writes into its cache (readable by others).
FILE_MODE = 0o644

#: Suffix of the record written beside each file.
RECORD_SUFFIX = ".sha256"


class CacheError(InputError):
    """The cache folder cannot be used: the message names the variable, the path and why."""


def root() -> Path:
    """The cache folder: ``$ESBA_CACHE_DIR``, else ``$XDG_CACHE_HOME/esba``, else ``~/.cache/esba``."""
    env = os.environ.get("ESBA_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "esba"


def _where() -> str:
    if os.environ.get("ESBA_CACHE_DIR"):
        return "ESBA_CACHE_DIR"
    return "XDG_CACHE_HOME" if os.environ.get("XDG_CACHE_HOME") else "the cache folder"


def usable_root(folder: Path | None = None) -> Path:
    """``folder`` (default: a subfolder of :func:`root`) created if needed and writable, else :class:`CacheError`."""
    base = root()
    folder = base if folder is None else Path(folder)
    name = f"{_where()}={str(base)!r}" if folder == base or base in folder.parents else f"cache folder {str(folder)!r}"
    for part in [*reversed(folder.parents), folder]:
        if part.exists() and not part.is_dir():
            raise CacheError(f"{name}: {str(part)!r} is a file, expected a folder (point ESBA_CACHE_DIR at a writable folder)")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".esba-write-test-", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise CacheError(f"{name}: cannot write there ({exc.strerror or exc}); point ESBA_CACHE_DIR at a writable folder") from None
    return folder


def record_path(path: Path) -> Path:
    """The record beside ``path`` (``NAME.sha256``)."""
    return path.with_name(path.name + RECORD_SUFFIX)


def _atomic(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically, record first, both 0644; return the path.

    A file written into the cache folder then keeps the cache within :func:`limit` (the least
    recently used other files go first)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    _atomic(record_path(path), (json.dumps(record) + "\n").encode())
    _atomic(path, data)
    _keep_within_limit(path)
    return path


def write_text(path: str | Path, text: str) -> Path:
    """:func:`write_bytes` of UTF-8 text."""
    return write_bytes(path, text.encode("utf-8"))


def install(path: str | Path, source: str | Path) -> Path:
    """Copy the file ``source`` (e.g. a freshly compiled library) to ``path`` with its record."""
    return write_bytes(path, Path(source).read_bytes())


def read_verified(path: str | Path) -> tuple[bytes | None, str | None]:
    """(the content of the cached file ``path``, None) when it is exactly what was written, else
    (None, why it may not be used). The file is read once: check and use see the same bytes."""
    path = Path(path)
    if path.is_dir():
        return None, "a folder is in its place"
    if not path.is_file():
        return None, "missing"
    try:
        record = json.loads(record_path(path).read_text(encoding="utf-8"))
        expected_size, expected_hash = int(record["bytes"]), str(record["sha256"])
    except FileNotFoundError:
        return None, "no checksum recorded (written by an older esba, or interrupted)"
    except (OSError, ValueError, KeyError, TypeError):
        return None, "its checksum record is unreadable"
    size = path.stat().st_size
    if size != expected_size:
        return None, f"truncated or changed: {size} bytes, {expected_size} expected"
    try:
        data = path.read_bytes()
    except OSError as exc:
        return None, f"unreadable ({exc.__class__.__name__})"
    if len(data) != expected_size or hashlib.sha256(data).hexdigest() != expected_hash:
        return None, "changed since it was written (sha256 differs)"
    _touch(path)
    return data, None


def damage(path: str | Path) -> str | None:
    """Why the cached file ``path`` may not be used, or None when it is exactly what was written."""
    return read_verified(path)[1]


#: Shared libraries this process has seen a child process load (path, inode, size, mtime).
_LOADED: set[tuple[str, int, int, int]] = set()


def library_damage(path: str | Path, timeout: float = 120.0) -> str | None:
    """Why the cached shared library ``path`` may not be loaded, or None.

    Its checksum (:func:`damage`) first; then a child process loads it (``ctypes.CDLL``): a
    library damaged while its checksum record was made to match (truncated, its pages past the
    end of the file) would kill the loading process with a bus error, and this way it kills only
    the child. Once per process for each file.
    """
    why = damage(path)
    if why is not None:
        return why
    path = Path(path)
    try:
        st = path.stat()
    except OSError as exc:
        return f"unreadable ({exc.__class__.__name__})"
    key = (str(path.resolve()), st.st_ino, st.st_size, st.st_mtime_ns)
    if key in _LOADED:
        return None
    probe = "import ctypes, sys; ctypes.CDLL(sys.argv[1])"
    try:
        p = subprocess.run([sys.executable, "-c", probe, str(path)], capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"it could not be test-loaded ({exc.__class__.__name__})"
    if p.returncode < 0:
        try:
            name = signal.Signals(-p.returncode).name
        except ValueError:
            name = f"signal {-p.returncode}"
        return f"loading it killed a test process ({name})"
    if p.returncode != 0:
        last = (p.stderr.strip().splitlines() or ["exit " + str(p.returncode)])[-1]
        return f"it does not load ({last[:200]})"
    _LOADED.add(key)
    return None


def discard(path: str | Path) -> None:
    """Remove the cached ``path`` (a file, or a folder in its place) and its record."""
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)
    record_path(path).unlink(missing_ok=True)


# --- what the cache holds, and keeping it bounded -------------------------------------------------

#: The kinds of file in the cache: its top-level folders, and what each holds.
KINDS = {
    "models": "models generated on demand (Python source, one folder per derivation source)",
    "models3d": "3-D models generated on demand (Python source, one folder per derivation source)",
    "functions": "built CasADi Functions, serialised and compressed (a model loads in milliseconds, not seconds)",
    "compiled": "compiled Newton kernels and batch solvers (shared libraries)",
    "export": "C code generated for esba export c",
}

#: The bound of the cache when ``$ESBA_CACHE_MAX`` is not set, bytes.
DEFAULT_LIMIT = 1 << 30

#: After a write finds the cache over its bound, it is pruned to this share of the bound.
PRUNE_TO = 0.8

_UNITS = {"": 1, "B": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def parse_size(text: str, what: str = "size") -> int:
    """Bytes from ``text``: a whole number with an optional K, M, G or T suffix (powers of 1024).

    >>> parse_size("200M"), parse_size("1G"), parse_size("4096"), parse_size("0")
    (209715200, 1073741824, 4096, 0)
    >>> parse_size("lots", "--to")
    Traceback (most recent call last):
    ...
    esba.infra.cache.CacheError: --to 'lots': expected a size in bytes, e.g. 500M, 2G or 0 (a whole number with an optional K, M, G or T)
    """
    t = str(text).strip().upper()
    for suffix in ("IB", "B"):  # 500MiB, 500MB and 500M alike
        if t.endswith(suffix) and len(t) > len(suffix):
            t = t[: -len(suffix)]
            break
    unit = t[-1] if t and t[-1] in _UNITS else ""
    digits = t[: len(t) - len(unit)]
    if not digits.isascii() or not digits.isdigit() or len(digits) > 18:
        raise CacheError(f"{what} {str(text)[:40]!r}: expected a size in bytes, e.g. 500M, 2G or 0 (a whole number with an optional K, M, G or T)")
    return int(digits) * _UNITS[unit]


def limit() -> int | None:
    """The cache's bound in bytes from ``$ESBA_CACHE_MAX`` (default :data:`DEFAULT_LIMIT`); None
    when it is ``0`` (no bound)."""
    text = os.environ.get("ESBA_CACHE_MAX")
    if text is None or text.strip() == "":
        return DEFAULT_LIMIT
    size = parse_size(text, "ESBA_CACHE_MAX")
    return size or None


@dataclass(frozen=True)
class CacheFile:
    """One file of the cache with its checksum record: its kind (top-level folder), size (file and
    record, bytes) and when it was last used (written, or read and verified; seconds since the epoch)."""

    path: Path
    kind: str
    bytes: int
    used: float


def _touch(path: Path) -> None:
    """Mark ``path`` as used now (its mtime), for least-recently-used pruning; a cache that cannot
    be written (shared, read-only) is simply not marked."""
    try:
        os.utime(path)
    except OSError:
        pass


def files(folder: Path | None = None) -> list[CacheFile]:
    """Every file of the cache (records and temporary files counted with their file), oldest use first."""
    base = root() if folder is None else Path(folder)
    if not base.is_dir():
        return []
    found = []
    for dirpath, _dirs, names in os.walk(base):
        here = Path(dirpath)
        kind = here.relative_to(base).parts[0] if here != base else "other"
        for name in names:
            if name.endswith(RECORD_SUFFIX) or name.startswith("."):
                continue
            path = here / name
            try:
                st = path.lstat()
            except OSError:
                continue
            try:
                extra = record_path(path).lstat().st_size
            except OSError:
                extra = 0
            found.append(CacheFile(path, kind if kind in KINDS else "other", st.st_size + extra, st.st_mtime))
    return sorted(found, key=lambda f: (f.used, str(f.path)))


def usage(folder: Path | None = None) -> dict:
    """What the cache holds: its folder, bound, and the files and bytes of each kind."""
    base = root() if folder is None else Path(folder)
    all_files = files(base)
    kinds = {k: {"files": 0, "bytes": 0, "about": about} for k, about in (*KINDS.items(), ("other", "anything else"))}
    for f in all_files:
        kinds[f.kind]["files"] += 1
        kinds[f.kind]["bytes"] += f.bytes
    return {"folder": str(base), "limit_bytes": limit(), "files": len(all_files), "bytes": sum(f.bytes for f in all_files), "kinds": kinds}


def _remove(f: CacheFile) -> bool:
    try:
        discard(f.path)
    except OSError:
        return False
    return True


def prune(max_bytes: int, folder: Path | None = None, keep: Path | None = None) -> list[CacheFile]:
    """Remove the least recently used files until the cache holds at most ``max_bytes``; return them.

    ``keep``: a file never removed (the one just written). Empty folders left behind are removed.
    """
    all_files = files(folder)
    total = sum(f.bytes for f in all_files)
    removed = []
    for f in all_files:
        if total <= max_bytes:
            break
        if f.kind == "other" or (keep is not None and f.path == keep):  # only what esba itself keeps there
            continue
        if _remove(f):
            total -= f.bytes
            removed.append(f)
    _remove_empty_folders(root() if folder is None else Path(folder))
    return removed


def clear(folder: Path | None = None) -> list[CacheFile]:
    """Remove every file esba keeps in the cache (its own folders, :data:`KINDS`: nothing else that
    ``$ESBA_CACHE_DIR`` may hold)."""
    return prune(0, folder)


def _remove_empty_folders(base: Path) -> None:
    for dirpath, _dirs, _names in sorted(os.walk(base), key=lambda w: -len(w[0])):
        if Path(dirpath) != base and Path(dirpath).relative_to(base).parts[0] in KINDS:
            try:
                os.rmdir(dirpath)
            except OSError:
                pass


def _keep_within_limit(written: Path) -> None:
    """After a write into the cache: prune it when it is over its bound (a bad ``$ESBA_CACHE_MAX``
    is reported by ``esba cache``, not by every write)."""
    try:
        base = root().resolve()
        if base not in written.resolve().parents:
            return
        bound = limit()
    except (OSError, CacheError):
        return
    if bound is not None and sum(f.bytes for f in files(base)) > bound:
        prune(int(bound * PRUNE_TO), base, keep=written.resolve())
