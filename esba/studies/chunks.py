"""Chunked studies: solved chunk by chunk on a runner, written to a file as they come, resumable.

A large sweep or Monte Carlo is split into chunks of points (:func:`chunk_bounds`), each solved by
a pure function on a runner of :mod:`esba.studies.distributed` (:func:`run_chunks`: in this process or on
Dask workers, results handed back in chunk order, a tqdm bar on completed chunks). Each chunk's
rows are appended to a :class:`StudyFile` as soon as it and every chunk before it are solved, so
the file always holds the first k rows of the study, in order, and an interrupted study resumes
from row k.

The file is plain CSV, column names first (``pandas.read_csv(path)`` reads it as it is), and the
study's metadata is a JSON file beside it, the same name with ``.study.json`` for ``.csv``
(:func:`sidecar`, read by :func:`read_header`)::

    grid.csv          pressure_mpa,payload_n,...
                      0.0,0.0,...
    grid.study.json   {"kind": "sweep", "hash": "9f0c...", "rows": 2000, "settings": {...}, "identity": {...}}

``identity`` is everything that fixes the study's answers (the grid or the samples, the model,
the batch settings, the esba code); ``hash`` is its SHA-256, and a resumed study must have the
same. ``settings`` records decisions taken when the study started (whether the batch path runs
compiled), which a resumed study keeps. Every writer of a study's CSV (a sweep in this process
included) writes both, under the same lock.

While a run writes the file it holds an exclusive lock on it (``flock``, on POSIX systems): a
second run that starts or resumes the same file is refused (:class:`StudyError`) instead of
writing rows twice. Each chunk's rows reach the disk in one write followed by ``fsync``; a write
that fails (a full disk) is undone, so the file keeps whole chunks, and the study stops with
:class:`StudyStopped`. Resuming reads every row back and refuses one that is not exactly what
the writer writes (a stray quote, a changed separator), leaving the file as it is.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "s.csv"
>>> f = StudyFile(path, "demo", {"grid": [1, 2, 3]}, ["x", "y"], rows=3)
>>> f.start({"compile": "never"})
>>> f.append([{"x": 1, "y": 1.5}, {"x": 2, "y": None}])
>>> f.close()
>>> g = StudyFile(path, "demo", {"grid": [1, 2, 3]}, ["x", "y"], rows=3)
>>> g.resume(), g.settings
(2, {'compile': 'never'})
>>> g.close()
>>> StudyFile(path, "demo", {"grid": [1, 2]}, ["x", "y"], rows=2).resume()  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.studies.chunks.StudyError: --resume ...s.csv: the file belongs to another study (hash ..., this study ...): it differs in grid, rows; ...
"""

from __future__ import annotations

import csv
import errno
import hashlib
import io
import json
import logging
import os
import stat
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

from esba.infra import inputs
from esba.infra.errors import InputError
from esba.infra.outputs import WriteFailed

from .distributed import StudyStopped, run_task

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: studies are not locked
    fcntl = None  # type: ignore[assignment]

__all__ = ["StudyError", "StudyStopped", "StudyFile", "study_hash", "sidecar", "read_header", "write_study", "checked_rows", "chunk_bounds", "run_chunks",
           "HEADER", "MAX_CHUNK"]

_log = logging.getLogger("esba.studies.chunks")

#: The start of the first line of a study file written by esba before 0.1.0's sidecar files (the
#: JSON header followed it in the CSV): recognised only to refuse resuming such a file.
HEADER = "# esba-study "

#: The suffix of a study's metadata file, beside its CSV (``grid.csv``: ``grid.study.json``).
SIDECAR_SUFFIX = ".study.json"


def sidecar(path: str | Path) -> Path:
    """The metadata file of the study CSV at ``path``.

    >>> sidecar("runs/grid.csv").as_posix()
    'runs/grid.study.json'
    """
    path = Path(path)
    return path.with_name(path.stem + SIDECAR_SUFFIX)


def read_header(path: str | Path) -> dict[str, Any] | None:
    """The metadata (kind, hash, rows, settings, identity) of the study CSV at ``path``, or None
    when there is no readable metadata file beside it."""
    try:
        header = json.loads(sidecar(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return header if isinstance(header, dict) else None

#: The most points one chunk may hold (its arrays travel whole between processes).
MAX_CHUNK = 1_000_000


class StudyError(InputError):
    """A study file that cannot be written or resumed: the message names the file and what is wrong."""


def study_hash(identity: Mapping[str, Any]) -> str:
    """SHA-256 (hex, 16 characters) of a JSON-ready identity, keys sorted.

    >>> study_hash({"a": 1, "b": [0.5]}) == study_hash({"b": [0.5], "a": 1})
    True
    """
    text = json.dumps(identity, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _differences(a: Any, b: Any, prefix: str = "") -> list[str]:
    """Paths (``plan.axes.pressure``) where two JSON values differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            out += _differences(a.get(k), b.get(k), f"{prefix}.{k}" if prefix else str(k))
        return out
    return [] if a == b else [prefix or "(all)"]


class StudyFile:
    """The CSV file of a chunked study: its header line, column names and rows in study order.

    Parameters
    ----------
    path : str or Path
        A ``.csv`` file.
    kind : str
        ``sweep``, ``monte-carlo``, ...
    identity : dict
        JSON-ready: everything that fixes the study's answers (:func:`study_hash`).
    columns : sequence of str
    rows : int
        Rows of the whole study.
    """

    def __init__(self, path: str | Path, kind: str, identity: Mapping[str, Any], columns: Sequence[str], rows: int) -> None:
        self.path = Path(path)
        self.kind = kind
        self.identity = json.loads(json.dumps(identity, allow_nan=False))  # tuples as lists, as read back
        self.columns = list(columns)
        self.rows = int(rows)
        self.hash = study_hash({"kind": kind, "rows": self.rows, "columns": self.columns, "identity": self.identity})
        self.settings: dict[str, Any] = {}
        #: Rows of this same study that the file held when :meth:`start` replaced them.
        self.replaced = 0
        self._fd: int | None = None
        self._size = 0  # bytes on disk: the header, the column names and whole rows
        if self.path.suffix.lower() != ".csv":
            raise StudyError(f"{self.path}: a study written chunk by chunk is a .csv file")

    # -- the lock ------------------------------------------------------------------------------

    def _acquire(self, flags: int, what: str) -> int:
        """Open the file with ``flags`` and lock it for this run (exclusive, not waiting).

        Only a regular file (or none yet) is a study file: a FIFO would wait for a reader or a
        writer, ``/dev/zero`` would be read without end, ``/dev/full`` has no rows to resume.
        """
        kind = inputs.special_kind(self.path)
        if kind:
            raise StudyError(f"{self.path}: {kind}, not a regular file; a study is written to (and resumed from) a regular .csv file")
        try:
            fd = os.open(self.path, flags | getattr(os, "O_CLOEXEC", 0), 0o666)
        except OSError as exc:
            raise StudyError(f"{what} ({exc.strerror or exc})") from None
        if fcntl is None:  # pragma: no cover - not POSIX
            return fd
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                _log.warning("%s: its file system cannot lock files (%s): do not run two studies on this file at once", self.path, exc.strerror or exc)
                return fd
            holder = _lock_holder(fd)
            os.close(fd)
            raise StudyError(
                f"{self.path} is being written by another esba run{f' (pid {holder})' if holder else ''}: "
                "wait for it to end, or give another file"
            ) from None
        return fd

    def check_free(self) -> None:
        """Refuse (:class:`StudyError`) now, before a long computation, a file that another run is
        writing; the lock itself is taken when the file is started or resumed."""
        if self.path.exists():
            os.close(self._acquire(os.O_RDONLY, f"{self.path}: cannot read the study file"))

    # -- writing -------------------------------------------------------------------------------

    def start(self, settings: Mapping[str, Any]) -> None:
        """Begin a new file (replacing any file at ``path``) with the header and the column names.

        When the file held rows of this same study, :attr:`replaced` says how many (and a line is
        logged): they are solved again.
        """
        self.settings = dict(settings)
        header = {"kind": self.kind, "hash": self.hash, "rows": self.rows, "settings": self.settings, "identity": self.identity}
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StudyError(f"{self.path}: cannot make its folder ({exc.strerror or exc})") from None
        fd = self._acquire(os.O_WRONLY | os.O_CREAT | os.O_APPEND, f"{self.path}: cannot write the study file")
        self.replaced = self._rows_of_this_study()  # from the old metadata: read before it is replaced
        meta, tmp = sidecar(self.path), sidecar(self.path).with_name(sidecar(self.path).name + f".{os.getpid()}.tmp")
        try:  # whole or not at all: written beside it, then renamed over the old one
            tmp.write_text(json.dumps(header, sort_keys=True, allow_nan=False, indent=1) + "\n", encoding="utf-8")
            os.replace(tmp, meta)
        except OSError as exc:  # a full disk is a run-time failure (exit 1); the CSV is not cut yet, so it is kept as it was
            tmp.unlink(missing_ok=True)
            os.close(fd)
            raise WriteFailed(f"{meta}: cannot write the study's metadata ({exc.strerror or exc}); {self.path} is left as it was") from None
        try:
            if stat.S_ISREG(os.fstat(fd).st_mode):  # not a device (a pipe, /dev/null)
                os.ftruncate(fd, 0)  # only now, under the lock, after the metadata is written
        except OSError as exc:
            os.close(fd)
            raise WriteFailed(f"{self.path}: cannot write the study file ({exc.strerror or exc})") from None
        if self.replaced:
            _log.warning("%s held %d rows of this study; starting over (give --resume to continue it)", self.path, self.replaced)
        self._fd, self._size = fd, 0
        names = io.StringIO()
        csv.writer(names, lineterminator="\n").writerow(self.columns)
        self._write(names.getvalue())

    def append(self, rows: Sequence[Mapping[str, Any]]) -> None:
        """Append rows (None as an empty cell) and push them to the disk.

        Raises
        ------
        StudyStopped
            when they cannot be written (a full disk): the file is cut back to the rows before them.
        """
        if self._fd is None:
            raise StudyError(f"{self.path}: the study file is not open (start() or resume() first)")
        buf = io.StringIO()
        csv.DictWriter(buf, fieldnames=self.columns, lineterminator="\n").writerows({k: ("" if v is None else v) for k, v in r.items()} for r in rows)
        self._write(buf.getvalue())

    def _write(self, text: str) -> None:
        """Write ``text`` whole and fsync it; on failure cut the file back to what it held before and close it."""
        assert self._fd is not None
        data = text.encode("utf-8")
        view = memoryview(data)
        try:
            while view:
                view = view[os.write(self._fd, view):]
            os.fsync(self._fd)
        except OSError as exc:
            try:
                os.ftruncate(self._fd, self._size)
            except OSError:  # pragma: no cover - cutting a file back frees space
                pass
            self.close()
            raise StudyStopped(f"{self.path}: cannot write ({exc.strerror or exc})", self.path) from None
        self._size += len(data)

    def close(self) -> None:
        """Close the file and release its lock (idempotent)."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            try:
                os.close(fd)
            except OSError:  # pragma: no cover - every row was fsynced already
                pass

    def __enter__(self) -> StudyFile:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- resuming ------------------------------------------------------------------------------

    def _bad(self, what: str) -> StudyError:
        return StudyError(f"--resume {self.path}: {what}; remove the file or give another output to start anew")

    def resume(self, on_row: Callable[[dict[str, str]], None] | None = None) -> int:
        """Check that the file at ``path`` is this study's, keep its complete rows and open it for appending.

        ``on_row`` is called with each complete row (column -> text) in order. A row cut short
        (the study stopped while writing a chunk) is removed. Returns the number of rows kept;
        :attr:`settings` is the file's.

        Raises
        ------
        StudyError
            for a file that another run is writing, that is not a study file, another study's (the
            message says what differs), a row that is not exactly what the writer writes (a stray
            quote, the wrong number of cells), or more rows than the study has. The file is left
            as it is.
        """
        fd = self._acquire(os.O_RDWR | os.O_APPEND, f"--resume {self.path}: cannot read the study file")
        try:
            with open(self.path, "rb") as fb:
                names = fb.readline()
                header = self._header(names)
                self.settings = dict(header.get("settings") or {})
                if names.decode("utf-8", "replace").rstrip("\r\n") != ",".join(self.columns):
                    raise self._bad(f"its column names are not this study's ({names[:80].decode('utf-8', 'replace').strip()!r}...)")
                end, count = self._rows(fb, len(names), on_row)
            if end < os.fstat(fd).st_size:
                os.ftruncate(fd, end)  # a chunk cut short: its complete rows stay, the broken tail goes
        except OSError as exc:
            os.close(fd)
            raise StudyError(f"--resume {self.path}: cannot read the study file ({exc.strerror or exc})") from None
        except BaseException:
            os.close(fd)
            raise
        self._fd, self._size = fd, end
        return count

    def _header(self, first: bytes) -> dict:
        """The study's metadata from the file beside the CSV (``first`` is the CSV's first line)."""
        if first.startswith(HEADER.encode()):
            raise self._bad(f"it was written by an older esba, with its metadata on its first line ({HEADER.strip()!r}), not in {sidecar(self.path).name}")
        meta = sidecar(self.path)
        try:
            header = json.loads(meta.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise self._bad(f"not a study file (no {meta.name} beside it: the study's metadata)") from None
        except OSError as exc:
            raise self._bad(f"cannot read its metadata {meta} ({exc.strerror or exc})") from None
        except ValueError:
            raise self._bad(f"its metadata {meta.name} is not valid JSON") from None
        if not isinstance(header, dict) or header.get("kind") != self.kind:
            kind = header.get("kind") if isinstance(header, dict) else None
            raise self._bad(f"it holds a {kind!r} study, not a {self.kind!r} one")
        if header.get("hash") == self.hash and (header.get("identity") != self.identity or header.get("rows") != self.rows):
            diff = _differences({"rows": header.get("rows"), **(header.get("identity") or {})}, {"rows": self.rows, **self.identity})
            raise self._bad(f"its header was edited: its hash is this study's but its {', '.join(diff[:3]) or 'identity'} is not")
        if header.get("hash") != self.hash:
            diff = _differences({"rows": header.get("rows"), **(header.get("identity") or {})}, {"rows": self.rows, **self.identity})
            what = ", ".join(diff[:6]) + (", ..." if len(diff) > 6 else "")
            raise StudyError(
                f"--resume {self.path}: the file belongs to another study (hash {header.get('hash')}, this study {self.hash}): "
                f"it differs in {what or 'its column names'}; remove the file or give another output to start anew"
            )
        return header

    def _cells(self, record: bytes) -> list[str] | None:
        """The cells of one record, or None when it is not exactly what the writer writes for them."""
        try:
            text = record.decode("utf-8")
            rows = list(csv.reader(io.StringIO(text, newline=""), strict=True))
        except (UnicodeDecodeError, csv.Error):
            return None
        if len(rows) != 1:
            return None
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(rows[0])
        return rows[0] if buf.getvalue() == text else None

    def _rows(self, fb, offset: int, on_row: Callable[[dict[str, str]], None] | None) -> tuple[int, int]:
        """Scan the complete rows (a quoted cell may hold line breaks): the end offset of the last one, and their count."""
        count, end, parts = 0, offset, []
        for raw in fb:
            parts.append(raw)
            record = b"".join(parts)
            if not raw.endswith(b"\n") or record.count(b'"') % 2:
                continue  # a line break inside a quoted cell, or the cut-off tail
            parts = []
            cells = self._cells(record)
            if cells is None:
                raise self._bad(f"row {count + 1} cannot be read back exactly as CSV (a stray quote or separator?)")
            if len(cells) != len(self.columns):
                raise self._bad(f"row {count + 1} has {len(cells)} cells, the study {len(self.columns)}")
            count += 1
            if count > self.rows:
                raise self._bad(f"it has more rows than the study's {self.rows}")
            end += len(record)
            if on_row is not None:
                on_row(dict(zip(self.columns, cells)))
        if len(parts) > 1 and self._swallowed(parts):
            raise self._bad(f"row {count + 1} cannot be read back exactly as CSV (a quote that is never closed)")
        return end, count

    def _swallowed(self, lines: list[bytes]) -> bool:
        """Whether the unfinished record at the end of the file (lines) is a row with an unmatched
        quote followed by whole rows, rather than a row cut short inside a quoted cell."""
        return any(raw.endswith(b"\n") and (cells := self._cells(raw)) is not None and len(cells) == len(self.columns) for raw in lines[1:])

    def _rows_of_this_study(self) -> int:
        """Complete rows of this same study (same hash) in the file now; 0 for anything else."""
        try:
            header = read_header(self.path)
            if header is None or header.get("hash") != self.hash:
                return 0
            with open(self.path, "rb") as fb:
                names = fb.readline()
                return self._rows(fb, len(names), None)[1]
        except (OSError, StudyError):
            return 0


def write_study(path: str | Path, kind: str, identity: Mapping[str, Any], columns: Sequence[str], rows: Sequence[Mapping[str, Any]], settings: Mapping[str, Any]) -> StudyFile:
    """Write a whole study (every row at once) as :class:`StudyFile` does chunk by chunk: the same
    CSV and metadata file, under the same lock. Returns the closed file (its :attr:`StudyFile.replaced`)."""
    with StudyFile(path, kind, identity, columns, len(rows)) as file:
        file.start(settings)
        file.append(rows)
    return file


def _lock_holder(fd: int) -> int | None:
    """The process holding a ``flock`` on the file of ``fd`` (Linux: /proc/locks), else None."""
    try:
        st = os.fstat(fd)
        with open("/proc/locks", encoding="ascii") as fh:
            for line in fh:
                f = line.split()
                if len(f) > 5 and f[1] == "FLOCK" and f[3] == "WRITE":
                    major, minor, inode = f[5].split(":")
                    if (int(major, 16), int(minor, 16), int(inode)) == (os.major(st.st_dev), os.minor(st.st_dev), st.st_ino):
                        return int(f[4])
    except (OSError, ValueError):
        pass
    return None


def checked_rows(out: str | Path, problem: Callable[[int, dict[str, str]], str], keep: Callable[[dict[str, str]], None]) -> Callable[[dict[str, str]], None]:
    """An ``on_row`` for :meth:`StudyFile.resume`: each row the file holds is checked by
    ``problem(index, row)`` (``""``: it is what the study writes there) before ``keep(row)``;
    the first that is not raises a :class:`StudyError` naming it, and the file is left as it is."""
    index = 0

    def on_row(row: dict[str, str]) -> None:
        nonlocal index
        why = problem(index, row)
        if why:
            raise StudyError(f"--resume {out}: row {index + 1} {why}; it is not kept: remove the file or give another output to start anew")
        index += 1
        keep(row)

    return on_row


def chunk_bounds(start: int, stop: int, chunk: int) -> list[tuple[int, int]]:
    """``[(start, start + chunk), ...]`` up to ``stop``.

    >>> chunk_bounds(3, 10, 4)
    [(3, 7), (7, 10)]
    """
    return [(a, min(stop, a + chunk)) for a in range(start, stop, chunk)]


def run_chunks(
    runner,
    key,
    fn: Callable[..., Any],
    bounds: Sequence[tuple[int, int]],
    args_of: Callable[[int, int], tuple],
    on_result: Callable[[int, int, Any], None],
    progress: str | None = None,
) -> None:
    """Solve every chunk ``(a, b)`` of ``bounds`` as ``fn(*args_of(a, b))`` on ``runner`` (through
    :func:`esba.studies.distributed.run_task` with the :class:`esba.studies.distributed.ModelKey` ``key``) and
    call ``on_result(a, b, result)`` in chunk order. With ``progress`` (the bar's label) a tqdm bar
    on stderr counts the points of completed chunks."""
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=sum(b - a for a, b in bounds), unit="pt", desc=progress, leave=False, disable=None)  # None: only on a terminal

    def done(i: int) -> None:
        a, b = bounds[i]
        bar.update(b - a)

    results: Iterator[Any] = runner.map_ordered(run_task, ((key, fn, *args_of(a, b)) for a, b in bounds), done=done if bar is not None else None)
    try:
        for (a, b), result in zip(bounds, results):
            on_result(a, b, result)
    finally:
        results.close()  # type: ignore[attr-defined]
        if bar is not None:
            bar.close()
