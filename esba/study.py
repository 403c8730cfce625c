"""Chunked studies: solved chunk by chunk on a runner, written to a file as they come, resumable.

A large sweep or Monte Carlo is split into chunks of points (:func:`chunk_bounds`), each solved by
a pure function on a runner of :mod:`esba.distributed` (:func:`run_chunks`: in this process or on
Dask workers, results handed back in chunk order, a tqdm bar on completed chunks). Each chunk's
rows are appended to a :class:`StudyFile` as soon as it and every chunk before it are solved, so
the file always holds the first k rows of the study, in order, and an interrupted study resumes
from row k.

The file is CSV with one line before the column names::

    # esba-study {"kind": "sweep", "hash": "9f0c...", "rows": 2000, "settings": {...}, "identity": {...}}
    pressure_mpa,payload_n,...
    0.0,0.0,...

``identity`` is everything that fixes the study's answers (the grid or the samples, the model,
the batch settings, the esba code); ``hash`` is its SHA-256, and a resumed study must have the
same. ``settings`` records decisions taken when the study started (whether the batch path runs
compiled), which a resumed study keeps. Read the file with ``csv`` after skipping the first line,
or ``pandas.read_csv(path, skiprows=1)``.

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
esba.study.StudyError: --resume ...s.csv: the file belongs to another study (hash ..., this study ...): it differs in grid, rows; ...
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

__all__ = ["StudyError", "StudyFile", "study_hash", "chunk_bounds", "run_chunks", "HEADER", "MAX_CHUNK"]

#: The start of a study file's first line; the JSON header follows.
HEADER = "# esba-study "

#: The most points one chunk may hold (its arrays travel whole between processes).
MAX_CHUNK = 1_000_000


class StudyError(ValueError):
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
        self._fh: io.TextIOWrapper | None = None
        self._writer: csv.DictWriter | None = None
        if self.path.suffix.lower() != ".csv":
            raise StudyError(f"{self.path}: a study written chunk by chunk is a .csv file")

    # -- writing -------------------------------------------------------------------------------

    def _open(self, mode: str) -> None:
        try:
            self._fh = open(self.path, mode, encoding="utf-8", newline="")
        except OSError as exc:
            raise StudyError(f"{self.path}: cannot write the study file ({exc.strerror or exc})") from None
        self._writer = csv.DictWriter(self._fh, fieldnames=self.columns, lineterminator="\n")

    def start(self, settings: Mapping[str, Any]) -> None:
        """Begin a new file (replacing any file at ``path``) with the header and the column names."""
        self.settings = dict(settings)
        header = {"kind": self.kind, "hash": self.hash, "rows": self.rows, "settings": self.settings, "identity": self.identity}
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StudyError(f"{self.path}: cannot make its folder ({exc.strerror or exc})") from None
        self._open("w")
        assert self._fh is not None and self._writer is not None
        self._fh.write(HEADER + json.dumps(header, sort_keys=True, allow_nan=False) + "\n")
        self._writer.writeheader()
        self._sync()

    def append(self, rows: Sequence[Mapping[str, Any]]) -> None:
        """Append rows (None as an empty cell) and push them to the disk."""
        if self._writer is None:
            raise StudyError(f"{self.path}: the study file is not open (start() or resume() first)")
        self._writer.writerows({k: ("" if v is None else v) for k, v in r.items()} for r in rows)
        self._sync()

    def _sync(self) -> None:
        assert self._fh is not None
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._fh is not None:
            self._fh.close()
        self._fh = self._writer = None

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
            for a file that is not a study file, another study's (the message says what differs),
            a row with the wrong number of cells, or more rows than the study has.
        """
        try:
            fb = open(self.path, "rb")
        except OSError as exc:
            raise StudyError(f"--resume {self.path}: cannot read the study file ({exc.strerror or exc})") from None
        with fb:
            first = fb.readline()
            header = self._header(first)
            self.settings = dict(header.get("settings") or {})
            names = fb.readline()
            if names.decode("utf-8", "replace").rstrip("\r\n") != ",".join(self.columns):
                raise self._bad(f"its column names are not this study's ({names[:80].decode('utf-8', 'replace').strip()!r}...)")
            end, count = self._rows(fb, len(first) + len(names), on_row)
        size = self.path.stat().st_size
        if end < size:
            os.truncate(self.path, end)  # a chunk cut short: its complete rows stay, the broken tail goes
        self._open("a")
        return count

    def _header(self, first: bytes) -> dict:
        text = first.decode("utf-8", "replace")
        if not text.startswith(HEADER):
            raise self._bad(f"not a study file written chunk by chunk (its first line does not start with {HEADER.strip()!r})")
        try:
            header = json.loads(text[len(HEADER):])
        except ValueError:
            raise self._bad("its header line is not valid JSON") from None
        if not isinstance(header, dict) or header.get("kind") != self.kind:
            kind = header.get("kind") if isinstance(header, dict) else None
            raise self._bad(f"it holds a {kind!r} study, not a {self.kind!r} one")
        if header.get("hash") != self.hash:
            diff = _differences({"rows": header.get("rows"), **(header.get("identity") or {})}, {"rows": self.rows, **self.identity})
            what = ", ".join(diff[:6]) + (", ..." if len(diff) > 6 else "")
            raise StudyError(
                f"--resume {self.path}: the file belongs to another study (hash {header.get('hash')}, this study {self.hash}): "
                f"it differs in {what or 'its column names'}; remove the file or give another output to start anew"
            )
        return header

    def _rows(self, fb, offset: int, on_row: Callable[[dict[str, str]], None] | None) -> tuple[int, int]:
        """Scan the complete rows (a quoted cell may hold line breaks): the end offset of the last one, and their count."""
        count, end, parts = 0, offset, []
        for raw in fb:
            parts.append(raw)
            record = b"".join(parts)
            if not raw.endswith(b"\n") or record.count(b'"') % 2:
                continue  # a line break inside a quoted cell, or the cut-off tail
            parts = []
            try:
                cells = next(csv.reader(io.StringIO(record.decode("utf-8"))))
            except (UnicodeDecodeError, csv.Error, StopIteration):
                raise self._bad(f"row {count + 1} cannot be read as CSV") from None
            if len(cells) != len(self.columns):
                raise self._bad(f"row {count + 1} has {len(cells)} cells, the study {len(self.columns)}")
            count += 1
            if count > self.rows:
                raise self._bad(f"it has more rows than the study's {self.rows}")
            end += len(record)
            if on_row is not None:
                on_row(dict(zip(self.columns, cells)))
        return end, count


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
    :func:`esba.distributed.run_task` with the :class:`esba.distributed.ModelKey` ``key``) and
    call ``on_result(a, b, result)`` in chunk order. With ``progress`` (the bar's label) a tqdm bar
    on stderr counts the points of completed chunks."""
    from .distributed import run_task

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=sum(b - a for a, b in bounds), unit="pt", desc=progress, leave=False)

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
