"""Where esba writes, and whether it can: output paths checked before any long computation.

Every command writes where the user is, and one rule says where the pages are, for every command
that writes or checks one (``esba docs``, ``validate``, ``audit``, ``experiments``, ``bench``, the
``--write-doc`` pages): the ``docs/`` folder of the esba checkout that holds the current folder,
whichever esba runs (an editable install, or ``pip install .`` run in the clone), and anywhere else
``./docs/`` (made when a page is first written there, as the README's ``mkdir -p docs``). The
repository's ``generated/`` is written only by the esba that runs from that checkout (an editable
install), and an installed esba never writes into its own package folder.

=====================  ==================================  ====================================
output                 in a checkout                       elsewhere
=====================  ==================================  ====================================
pages (``*.md``)       ``docs/NAME.md``                    ``./docs/NAME.md``
figures                ``docs/figures/``                   ``./docs/figures/``
generated models       ``generated/`` (+ manifest)         the model cache (:mod:`esba.infra.cache`)
=====================  ==================================  ====================================

An output path is checked up front (:func:`check_file`, :func:`check_folder`,
:func:`figure_file`): its folder must exist and be writable (probed by creating and removing a
temporary file, which also catches read-only file systems and works for root), nothing of the
wrong kind may be in the way, and a figure's suffix must be a format matplotlib writes. A bad
path raises :class:`OutputError` with one line naming the flag, the path and what is allowed.
A write that fails while the command runs, after the checks (a full disk, a quota), raises
:class:`WriteFailed` naming the file (:func:`write_text`).

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> figure_file(str(d), "--plot", "esba-solve.png") == d / "esba-solve.png"
True
>>> figure_file(str(d / "shape"), "--plot", "esba-solve.png").name
'shape.png'
>>> figure_file(str(d / "shape.xyz"), "--plot", "x.png")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.infra.outputs.OutputError: --plot '...shape.xyz': unsupported figure format '.xyz'; allowed are ... .png, ...
>>> check_file(d / "missing" / "page.md", "--out")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.infra.outputs.OutputError: --out '...page.md': the folder '...missing' does not exist (create it first)
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from functools import lru_cache
from pathlib import Path

from .errors import InputError, RunError

__all__ = [
    "OutputError",
    "WriteFailed",
    "write_text",
    "PACKAGE_ROOT",
    "checkout_root",
    "enclosing_checkout",
    "docs_dir",
    "figures_dir",
    "default_page",
    "check_file",
    "check_folder",
    "figure_file",
    "figure_suffixes",
]

#: The folder that holds the ``esba`` package: a checkout of the repository, or site-packages.
PACKAGE_ROOT = Path(__file__).resolve().parents[2]

#: Format of a figure path without a suffix.
DEFAULT_FIGURE_SUFFIX = ".png"


class OutputError(InputError):
    """An output path that cannot be written: the message names the flag, the path and why."""


class WriteFailed(RunError):
    """An output that could not be written while the command ran (a full disk, a quota, an I/O
    error): not bad input; the message names the file."""


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path``; a write that fails leaves no half-written file.

    Raises
    ------
    WriteFailed
        naming the file and the system's reason.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> write_text(pathlib.Path(tempfile.mkdtemp()) / "a.json", "{}").read_text()
    '{}'
    """
    path = Path(path)
    try:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
    except OSError as exc:
        try:
            if path.is_file():
                path.unlink()
        except OSError:  # pragma: no cover - the folder went away meanwhile
            pass
        raise WriteFailed(f"{path}: cannot write ({exc.strerror or exc})") from None
    return path


def is_checkout(root: Path = PACKAGE_ROOT) -> bool:
    """True when ``root`` is a checkout of the esba repository (not an installed package)."""
    if not all((root / d).is_dir() for d in ("derive", "generated", "docs", "esba")):
        return False
    try:
        text = (root / "pyproject.toml").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return False
    return 'name = "esba"' in text


def checkout_root(cwd: Path | None = None) -> Path | None:
    """The checkout esba runs from (an editable install), when the current folder is inside it;
    else None. Only this esba's own checkout takes its ``generated/`` models.

    >>> checkout_root(Path("/")) is None
    True
    """
    if not is_checkout():
        return None
    here = (Path.cwd() if cwd is None else Path(cwd)).resolve()
    return PACKAGE_ROOT if here == PACKAGE_ROOT or PACKAGE_ROOT in here.parents else None


def enclosing_checkout(cwd: Path | None = None) -> Path | None:
    """The esba checkout that holds the current folder (or is it), whichever esba runs; else None.

    >>> enclosing_checkout(Path("/")) is None
    True
    """
    here = (Path.cwd() if cwd is None else Path(cwd)).resolve()
    for folder in (here, *here.parents):
        if is_checkout(folder):
            return folder
    return None


def docs_dir(create: bool = False) -> Path:
    """Where pages are, for writing and checking alike: the ``docs/`` of the checkout that holds the
    current folder, else ``./docs``; with ``create``, ``./docs`` is made when missing (one level)."""
    root = enclosing_checkout()
    folder = root / "docs" if root is not None else Path.cwd() / "docs"
    if create and not folder.is_dir():
        check_folder(folder, "the pages' folder")
    return folder


def figures_dir(create: bool = False) -> Path:
    """Where figures go by default: ``figures/`` beside the pages (:func:`docs_dir`)."""
    return docs_dir(create) / "figures"


def default_page(name: str, create: bool = False) -> Path:
    """The default path of the page ``name`` (e.g. ``"validation.md"``); ``create`` makes the
    pages' folder when missing (for a page about to be written)."""
    return docs_dir(create) / name


def _show(path: Path | str) -> str:
    return repr(str(path))


def _probe(folder: Path) -> str:
    """Why ``folder`` cannot take a new file, or "" when it can (a real write, then removed)."""
    try:
        fd, name = tempfile.mkstemp(prefix=".esba-write-test-", dir=folder)
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    os.close(fd)
    try:
        os.unlink(name)
    except OSError:  # pragma: no cover - created a moment ago
        pass
    return ""


def _no_trailing_separator(path: str | Path, flag: str) -> None:
    """A name ending in ``/`` means a folder: refused when no such folder exists (``Path`` would
    drop the slash and write a file of that name)."""
    text = str(path) if not isinstance(path, Path) else ""
    if text.endswith(("/", os.sep)) and not Path(text).is_dir():
        raise OutputError(f"{flag} {_show(text)}: ends in '/' but is not an existing folder; expected a file name (or an existing folder)")


def _no_symlink_loop(path: str | Path, flag: str) -> None:
    """A symlink that loops (``ln -s loop loop``), on its own or further up, names nothing that
    can be written: refused in one line (``Path.resolve`` would raise a bare RuntimeError, a
    write "Too many levels of symbolic links" after the work)."""
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise OutputError(f"{flag} {_show(path)}: a symlink that loops (it points, through links, back at itself); expected a file or folder") from None
    except ValueError:  # a NUL in the name: the checks below say so
        pass


def check_folder(path: str | Path, flag: str, create: bool = True) -> Path:
    """An output folder that exists (or, with ``create``, whose parent does) and can be written.

    The folder is created when missing (one level only: a typo in a parent is an error).
    """
    folder = Path(path)
    if str(path) == "":
        raise OutputError(f"{flag} '': expected a folder")
    _no_symlink_loop(folder, flag)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{flag} {_show(folder)}: a file is in the way, expected a folder")
    if not folder.exists():
        parent = folder.resolve().parent
        if parent.exists() and not parent.is_dir():
            raise OutputError(f"{flag} {_show(folder)}: {_show(folder.parent)} is a file, not a folder")
        if not create or not parent.is_dir():
            where = parent if create else folder
            raise OutputError(f"{flag} {_show(folder)}: the folder {_show(where)} does not exist (create it first)")
        why = _probe(parent)
        if why:
            raise OutputError(f"{flag} {_show(folder)}: cannot create it in {_show(parent)} ({why})")
        try:
            folder.mkdir()
        except FileExistsError:
            pass
        except OSError as exc:
            raise OutputError(f"{flag} {_show(folder)}: cannot create it ({exc.strerror})") from None
        return folder
    why = _probe(folder)
    if why:
        raise OutputError(f"{flag} {_show(folder)}: cannot write into it ({why})")
    return folder


def check_file(path: str | Path, flag: str, suffixes: tuple[str, ...] | None = None) -> Path:
    """An output file whose folder exists and is writable, with an allowed suffix.

    Parameters
    ----------
    path : str or Path
        The file to write (it may exist: it is replaced).
    flag : str
        The flag or field that named it, for the message (e.g. ``"--out"``).
    suffixes : tuple of str, optional
        Allowed suffixes, lower case with the dot (e.g. ``(".csv", ".json")``).
    """
    if str(path) == "":
        raise OutputError(f"{flag} '': expected a file name")
    _no_trailing_separator(path, flag)
    _no_symlink_loop(path, flag)
    file = Path(path)
    if suffixes is not None and file.suffix.lower() not in suffixes:
        got = f"'{file.suffix}'" if file.suffix else "no suffix"
        raise OutputError(f"{flag} {_show(file)}: {got}; expected a file ending in {', '.join(suffixes)}")
    if file.is_dir():
        raise OutputError(f"{flag} {_show(file)}: is a folder, expected a file")
    try:
        mode = os.stat(file).st_mode
    except (OSError, ValueError):
        mode = 0
    if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):  # a write would wait for a reader
        raise OutputError(f"{flag} {_show(file)}: is a FIFO or socket, expected a file (a write would wait for a reader)")
    folder = file.resolve().parent if not file.is_symlink() else file.parent
    if not folder.exists():
        raise OutputError(f"{flag} {_show(file)}: the folder {_show(file.parent)} does not exist (create it first)")
    if not folder.is_dir():
        raise OutputError(f"{flag} {_show(file)}: {_show(file.parent)} is a file, not a folder")
    if file.exists() and not os.access(file, os.W_OK):
        raise OutputError(f"{flag} {_show(file)}: the file is not writable (permission denied)")
    why = _probe(folder)
    if why:
        raise OutputError(f"{flag} {_show(file)}: cannot write into {_show(file.parent)} ({why})")
    return file


@lru_cache(maxsize=1)
def figure_suffixes() -> tuple[str, ...]:
    """The figure formats matplotlib writes, as suffixes (``.png``, ``.pdf``, ``.svg``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted(f".{ext}" for ext in FigureCanvasBase.get_supported_filetypes()))


def figure_file(path: str | Path, flag: str, default_name: str) -> Path:
    """The file a figure flag means: an existing folder gets ``default_name`` inside it, a name
    without a suffix gets ``.png``; the suffix must be a format matplotlib writes.

    The returned path is the one written, so that the command can say exactly which file it wrote.
    """
    if str(path) == "":
        raise OutputError(f"{flag} '': expected a figure file (e.g. shape.png) or a folder")
    _no_trailing_separator(path, flag)
    _no_symlink_loop(path, flag)
    file = Path(path)
    if file.is_dir():
        file = file / default_name
    elif not file.suffix:
        file = file.with_name(file.name + DEFAULT_FIGURE_SUFFIX)
    if file.suffix.lower() not in figure_suffixes():
        raise OutputError(
            f"{flag} {_show(path)}: unsupported figure format '{file.suffix}'; allowed are {', '.join(figure_suffixes())}"
        )
    return check_file(file, flag)
