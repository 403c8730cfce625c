"""The flags of studies on Dask: ``--workers``, ``--scheduler``, ``--connect-timeout``,
``--chunk``; checked by :mod:`esba.studies.distributed` without importing Dask."""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path
from typing import Callable

from .arguments import UsageError
from .results import EXIT_FAILED


def _checked(check: Callable) -> Callable[[str], object]:
    """An argparse type from a check of :mod:`esba.studies.distributed` (imports no Dask)."""

    def parse(text: str):
        from esba.studies.distributed import DistributedError

        try:
            return check(text, flag=None)
        except DistributedError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return parse


def workers_arg(text: str) -> int:
    from esba.studies.distributed import check_workers

    return _checked(check_workers)(text)


def scheduler_arg(text: str) -> str:
    from esba.studies.distributed import check_address

    return _checked(check_address)(text)


def timeout_arg(text: str) -> float:
    from esba.studies.distributed import check_timeout

    return _checked(check_timeout)(text)


def chunk_arg(text: str) -> int:
    from esba.studies.chunks import MAX_CHUNK

    value = int(text) if re.fullmatch(r"\s*\d+\s*", text) else 0
    if not 1 <= value <= MAX_CHUNK:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number of points per chunk from 1 to {MAX_CHUNK}")
    return value


#: Seconds ``--scheduler`` waits for the scheduler and its first worker unless --connect-timeout says.
CONNECT_TIMEOUT = 10.0


def add_cluster_flags(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--workers", type=workers_arg, metavar="N", help=f"solve {what} on a local Dask cluster of N worker processes (the esba[dask] extra)")
    p.add_argument("--scheduler", type=scheduler_arg, metavar="ADDRESS", help=f"solve {what} on the Dask cluster of the scheduler at ADDRESS (tcp://HOST:PORT)")
    p.add_argument("--connect-timeout", type=timeout_arg, default=None, metavar="S", help=f"seconds to wait for --scheduler and its first worker (default {CONNECT_TIMEOUT:g})")


def on_cluster(args: argparse.Namespace) -> bool:
    """Whether the study runs on Dask; checks --workers, --scheduler and the extra before any
    computation, and sets ``args.connect_timeout`` (refused without --scheduler: it would be ignored)."""
    if args.workers is not None and args.scheduler is not None:
        raise UsageError("--workers N starts a local cluster and --scheduler ADDRESS uses an existing one: give one of the two")
    if args.connect_timeout is not None and args.scheduler is None:
        raise UsageError("--connect-timeout is the wait for --scheduler ADDRESS: it is not used without it")
    if args.connect_timeout is None:
        args.connect_timeout = CONNECT_TIMEOUT
    if args.workers is None and args.scheduler is None:
        return False
    from esba.studies.distributed import DistributedError, require_dask

    try:
        require_dask("--workers" if args.workers is not None else "--scheduler")
    except DistributedError as exc:
        raise UsageError(str(exc)) from None
    return True


def study_stopped(exc: Exception, out: str | None, what: str = "rows") -> int:
    """One line for a study that stopped while it ran (:class:`esba.studies.chunks.StudyStopped`: a lost
    scheduler, a chunk whose workers kept dying, a full disk) and exit code 1. With ``out`` (the
    file the study streamed to) the line says that what was solved is kept there and how to go on."""
    message = str(exc)
    if out is not None:
        file = getattr(exc, "file", None)
        kept = "kept" if file is not None and Path(file) == Path(out) else f"in {out}"
        message += f"; the {what} solved so far are {kept}: rerun with --resume to go on"
    print(f"esba: error: {message}", file=sys.stderr)
    return EXIT_FAILED


def rows_held(path: str | None) -> int:
    """The lines after the column names in the study file ``path`` (0 when there is none, or it is
    not a regular file: a device or FIFO is refused by the study itself): a resumed study that holds
    every row of its plan solves nothing, so it needs no cluster (its rows are still checked one by
    one as they are read back). Counted in blocks: the memory stays bounded whatever the file holds."""
    if path is None or not os.path.isfile(path):
        return 0
    lines = 0
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                lines += block.count(b"\n")
    except OSError:
        return 0
    return max(0, lines - 1)
