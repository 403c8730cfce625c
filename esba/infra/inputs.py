"""Reading the files users give (scene files, measurement files): bounded, and only regular files.

A scene or measurement file is a few kilobytes of text. What is not a regular file (a FIFO,
``/dev/zero``, a terminal, a folder), or a symlink to one, would make a plain read wait forever or
fill the memory; a file past :data:`MAX_INPUT_BYTES` is not a scene. Both are refused in one
line naming the file, before anything is read. The text is UTF-8, with or without a byte-order
mark (editors on Windows write one), so every file kind treats a BOM alike.

TOML nested deeper than Python's recursion allows (``a = [[[[...]]]]`` 5000 deep) is refused as
not valid TOML, in one line, like any other TOML error.

Examples
--------
>>> import tempfile, pathlib
>>> p = pathlib.Path(tempfile.mkdtemp()) / "s.toml"
>>> _ = p.write_bytes(b"\\xef\\xbb\\xbfsegments = 3\\n")
>>> load_toml(p, "scene file", ValueError)
{'segments': 3}
>>> load_toml("/dev/zero", "scene file", ValueError)
Traceback (most recent call last):
...
ValueError: scene file '/dev/zero' cannot be read: a character device, not a regular file
"""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path
from typing import Any

from . import checks

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["MAX_INPUT_BYTES", "special_kind", "read_text", "load_toml"]

#: The largest scene or measurement file read (bytes): thousands of rows of measurements fit in
#: a few hundred kilobytes.
MAX_INPUT_BYTES = 16 * 1024 * 1024

_KINDS = [
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "it is a folder"),
]


def _show(path: str | Path) -> str:
    return repr(str(path))  # a path is bounded (PATH_MAX)


def special_kind(path: str | Path) -> str:
    """What ``path`` is when it exists and is not a regular file (``"a FIFO (named pipe) (through
    a symlink)"``), else ``""``.

    >>> special_kind("/dev/null")
    'a character device'
    """
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return ""
    for test, kind in _KINDS:
        if test(info.st_mode):
            return kind + (" (through a symlink)" if os.path.islink(path) else "")
    return ""


def read_text(path: str | Path, what: str, error: type[Exception]) -> str:
    """The UTF-8 text of the regular file ``path`` (a leading BOM dropped).

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages (``"scene file"``).
    error : type
        The caller's error class (``SceneError``, ``MeasurementError``, ...).
    """
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)) or str(path).strip() == "":
        raise error(f"{what} {checks.quote(path)}: expected the path of a file")
    where = f"{what} {_show(path)}"
    try:
        info = os.stat(path)  # follows a symlink: its target is what would be read
    except FileNotFoundError:
        raise error(f"{where} does not exist") from None
    except (OSError, ValueError) as exc:
        raise error(f"{where} cannot be read: {getattr(exc, 'strerror', None) or exc}") from None
    kind = special_kind(path)
    if kind:
        raise error(f"{where} cannot be read: {kind}, not a regular file")
    if info.st_size > MAX_INPUT_BYTES:
        raise error(f"{where}: {info.st_size} bytes; expected a file of at most {MAX_INPUT_BYTES // 2**20} MiB")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_INPUT_BYTES + 1)  # a file that grew meanwhile is still bounded
    except OSError as exc:
        raise error(f"{where} cannot be read: {exc.strerror or exc}") from None
    if len(data) > MAX_INPUT_BYTES:
        raise error(f"{where}: more than {MAX_INPUT_BYTES // 2**20} MiB; expected a smaller file")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{where} cannot be read: not UTF-8 text (byte {exc.start})") from None


def load_toml(path: str | Path, what: str, error: type[Exception]) -> dict[str, Any]:
    """The TOML document in ``path`` (:func:`read_text`); bad TOML is one line naming the file."""
    text = read_text(path, what, error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{what} {_show(path)} is not valid TOML: {str(exc).splitlines()[0] if str(exc) else exc}") from None
    except RecursionError:
        raise error(f"{what} {_show(path)} is not valid TOML: nested too deeply (arrays or tables inside each other)") from None
