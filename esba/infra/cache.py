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
from pathlib import Path

from .errors import InputError

__all__ = ["CacheError", "root", "usable_root", "write_bytes", "write_text", "install", "damage", "discard", "record_path"]

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
    """Write ``data`` to ``path`` atomically, record first, both 0644; return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    _atomic(record_path(path), (json.dumps(record) + "\n").encode())
    _atomic(path, data)
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
