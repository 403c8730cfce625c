"""The command line's terminal: closed pipes, progress lines from the library, exit codes.

* A reader that stops early (``esba sweep ... --json | head``) closes the pipe; the next write
  to stdout raises :class:`BrokenPipeError`, and Python would print a traceback (or "Exception
  ignored ...") at exit. :func:`run` ends such a command quietly with :data:`EXIT_PIPE` (128 +
  SIGPIPE, what a shell reports for a command killed by a closed pipe).
* A Ctrl-C after the command is done, while the interpreter shuts down, would kill the process
  by the signal with no word (Python gives SIGINT back to the system for its last teardown):
  :func:`exit_on_late_interrupt` makes it end as any interrupt does while Python still runs,
  and ignored in that last teardown.
* Library code never prints; it logs to the ``esba`` logger (a model generated on demand, a
  damaged cache file replaced). :func:`show_library_messages` sends those lines to stderr as
  ``esba: ...``.
"""

from __future__ import annotations

import atexit
import logging
import os
import signal
import sys
from typing import Callable

__all__ = ["EXIT_PIPE", "run", "show_library_messages", "exit_on_late_interrupt", "LOGGER"]

#: Exit code after the reader closed stdout (128 + SIGPIPE).
EXIT_PIPE = 141

#: The logger every esba module reports through.
LOGGER = "esba"


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the flush at exit does not raise again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # stdout without a file descriptor (captured in tests)
        pass


def _closed_stdout() -> bool:
    """When the command was started with stdout closed (``esba solve >&-``; Python then sets
    ``sys.stdout`` to None): put /dev/null on file descriptor 1, before any file the command opens
    could take that number (and receive what C libraries print), and let the prints go there."""
    if sys.stdout is not None:
        return False
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        if fd != 1:
            os.dup2(fd, 1)
            os.close(fd)
    except OSError:  # pragma: no cover - no /dev/null
        pass
    sys.stdout = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 - the process's stdout from here on
    return True


def run(command: Callable[[], int]) -> int:
    """Run ``command`` and flush stdout; a closed pipe ends it quietly with :data:`EXIT_PIPE`; a
    closed stdout is said on stderr in one line (the files the command writes are written)."""
    closed = _closed_stdout()
    try:
        code = command()
        sys.stdout.flush()
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_PIPE
    if closed and sys.stderr is not None:
        print("esba: warning: standard output was closed: what the command printed is lost", file=sys.stderr)
    return code


class _Handler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is at the time (so that captured stderr sees it)."""

    def __init__(self) -> None:
        super().__init__()
        self.setFormatter(logging.Formatter("esba: %(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr
        super().emit(record)


def show_library_messages(level: int = logging.INFO) -> None:
    """Print the ``esba`` logger's messages (``level`` and above) on stderr, once per process."""
    logger = logging.getLogger(LOGGER)
    if not any(isinstance(h, _Handler) for h in logger.handlers):
        logger.addHandler(_Handler())
    logger.setLevel(level)
    logger.propagate = False


def exit_on_late_interrupt(code: int, announce: bool = True) -> None:
    """For the program's last moments, after its command returned: SIGINT ends the process at once
    with ``code`` (after ``esba: interrupted`` on stderr when ``announce``) while Python code still
    runs (threads joined, exit handlers); in the interpreter's last teardown, where Python no
    longer runs signal handlers and would die by the signal with no word, it is ignored."""

    def handler(signum, frame) -> None:
        if announce:
            os.write(2, b"esba: interrupted\n")
        os._exit(code)

    global _LATE
    try:
        signal.signal(signal.SIGINT, handler)
    except ValueError:  # pragma: no cover - not the main thread
        return
    _LATE = True


_LATE = False


def _ignore_interrupts_at_teardown() -> None:
    """The last exit handler (registered when this module is imported, before Dask's): after it
    only the interpreter's C teardown is left."""
    if _LATE:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


atexit.register(_ignore_interrupts_at_teardown)
