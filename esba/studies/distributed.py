"""Where the chunks of a study run: in this process, or on the worker processes of a Dask cluster.

A study (a sweep grid, a Monte Carlo) is split into independent chunks, each solved by a pure
function of plain inputs (:func:`esba.studies.sweep.solve_points`, :func:`esba.calibration.uncertainty.solve_samples`)
that returns plain arrays. A *runner* maps such a function over the chunks and hands the
results back **in chunk order**, whatever order they finish in:

- :class:`SerialRunner`: one chunk after the other, in this process (no Dask needed);
- :class:`DaskRunner`: on a ``dask.distributed`` cluster, a local one of N worker processes
  (:func:`open_runner` with ``workers=N``: a ``LocalCluster`` with one thread per process) or an
  existing one (``scheduler=ADDRESS``: a scheduler started by ``dask scheduler``, by
  dask-jobqueue on SLURM/PBS, ...). At most ``window`` chunks are in flight or waiting to be
  handed back, so neither the scheduler nor this process holds more than that. When a worker
  dies, the scheduler runs its chunks again on another worker (a chunk's result is taken once:
  no row is lost or repeated); a chunk that raises an error stops the study with that error, and
  a chunk whose worker died at each try, or a lost connection to the scheduler, stops it with
  :class:`StudyStopped` (a failure at run time, not bad input).

Before Dask's client is handed a scheduler address, a probe with a hard deadline asks what
answers there who it is: Dask alone waits for ever on a service that accepts the connection but
does not answer (a web server), and reads the banner of one that speaks first (SSH) as the size of
a message, exabytes. While a cluster runs, the ``distributed`` loggers of this process are
silenced (esba says in one line what happened), and Ctrl-C while a local cluster starts or closes
is held until that step is over, then raised.

Every chunk runs through :func:`run_task` with a :class:`ModelKey`: the worker loads the model
itself with :func:`esba.model.generated.load_model` (once per process, by segment count, effects and
variant), after checking that its esba and its derivation source are the client's (their
hashes): no CasADi object is ever pickled. CasADi's ``nlpsol`` (the IPOPT fallback of the batch
path) is not safe to call from several threads, so local workers are processes with one thread
each, and a worker process of an existing cluster runs one esba chunk at a time whatever its
thread count (a lock).

Dask is an optional extra (``pip install "esba[dask]"``): without it, asking for workers or a
scheduler raises :class:`DistributedError` with a one-line message that names the extra.

Examples
--------
>>> runner = SerialRunner()
>>> list(runner.map_ordered(pow, [(2, 3), (3, 2)]))
[8, 9]
>>> check_workers("0")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
esba.studies.distributed.DistributedError: --workers '0': expected a whole number of worker processes from 1 to ...
>>> check_address("tcp://127.0.0.1:8786")
'tcp://127.0.0.1:8786'
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import signal
import socket
import threading
import time
import uuid
from concurrent.futures import CancelledError
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from esba.infra.errors import InputError, RunError
from esba.infra.interrupts import interrupts_raised

__all__ = [
    "DistributedError",
    "ModelKey",
    "SerialRunner",
    "DaskRunner",
    "open_runner",
    "run_task",
    "require_dask",
    "check_workers",
    "check_address",
    "check_timeout",
    "code_digest",
    "max_local_workers",
    "DASK_EXTRA",
]

#: How to install the optional extra (named in the message when Dask is missing).
DASK_EXTRA = 'pip install "esba[dask]"'

#: Chunks in flight or waiting to be handed back, per worker.
WINDOW_PER_WORKER = 4

#: Longest wait for a scheduler to answer or for its first worker, seconds.
MAX_TIMEOUT_S = 3600.0

#: A study stops when none of its chunks has come back and no worker of the cluster has run any of
#: them for this long, seconds (every worker gone and none coming back, or a chunk the scheduler
#: holds but gives to no worker): the wait ends in one line instead of never. A chunk that runs
#: for hours is not stopped: a worker is running it. A restarted worker is back in seconds.
STALL_S = 120.0
#: How often the wait for a chunk looks at the cluster, seconds.
POLL_S = 0.2
#: How often it asks the scheduler what its workers are running, seconds.
LOOK_S = 2.0

_TASK_LOCK = threading.Lock()


class StudyStopped(RunError):
    """A study that stopped before its end for a reason found while it ran, not in its input: the
    Dask scheduler was lost, a chunk's worker process died every time, the study file could not
    be written any more (a full disk). The chunks solved before it stay in the study's file, if it
    streams to one, and the study goes on from them when resumed.

    Attributes
    ----------
    file : Path or None
        The study file the message is about (a write that failed), else None.
    """

    def __init__(self, message: str, file: Path | None = None) -> None:
        super().__init__(message)
        self.file = file


class DistributedError(InputError):
    """A cluster that cannot be used: Dask missing, a bad flag, no scheduler, workers with another esba."""


def require_dask(flag: str) -> None:
    """Raise :class:`DistributedError` naming the extra when ``dask.distributed`` cannot be imported."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise DistributedError(f"{flag} needs Dask, an optional extra of esba: {DASK_EXTRA}") from None


def max_local_workers() -> int:
    """The most worker processes of a local cluster: 4 per core of this machine."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        cores = os.cpu_count() or 1
    return 4 * max(1, cores)


def _given(flag: str | None, text: Any) -> str:
    return f"{flag} {str(text)!r}" if flag else repr(str(text))


def check_workers(text: Any, flag: str | None = "--workers") -> int:
    """A local cluster's worker count from a flag's text: a whole number from 1 to :func:`max_local_workers`."""
    top = max_local_workers()
    try:
        value = int(str(text).strip())
    except ValueError:
        value = 0
    if not 1 <= value <= top:
        raise DistributedError(
            f"{_given(flag, text)}: expected a whole number of worker processes from 1 to {top} "
            f"(4 per core of this machine; for more, start a cluster and give --scheduler ADDRESS)"
        )
    return value


_ADDRESS = re.compile(r"^(?:(?P<scheme>[a-z]+)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>\d{1,5})$")
_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def check_address(text: Any, flag: str | None = "--scheduler") -> str:
    """A Dask scheduler address ``[tcp://]HOST:PORT`` (also tls, ws, wss, ucx), checked for its form only."""
    m = _ADDRESS.match(str(text).strip())
    if m is None or (m.group("scheme") or "tcp") not in _SCHEMES or not 1 <= int(m.group("port")) <= 65535:
        raise DistributedError(f"{_given(flag, text)}: expected a Dask scheduler address tcp://HOST:PORT (or HOST:PORT; tls, ws, wss, ucx also)")
    return str(text).strip()


def check_timeout(text: Any, flag: str | None = "--connect-timeout") -> float:
    """Seconds to wait for a scheduler: a number > 0 and <= 3600."""
    try:
        value = float(str(text))
    except ValueError:
        value = float("nan")
    if not 0.0 < value <= MAX_TIMEOUT_S:
        raise DistributedError(f"{_given(flag, text)}: expected seconds, a number > 0 and <= {MAX_TIMEOUT_S:g}")
    return value


# ---------------------------------------------------------------------------------------------
# what a worker checks and loads


#: The packages whose code decides a study's numbers (what ``code_digest`` covers): not the command
#: line, the figures, the pages or the benchmarks, whose edits cannot change a row.
COMPUTING_PACKAGES = ("infra", "model", "solvers", "paths", "solve", "analysis", "design", "calibration", "studies")


@lru_cache(maxsize=1)
def code_digest() -> str:
    """Hash of the code that computes a study's rows (every module of :data:`COMPUTING_PACKAGES`)
    and of the derivation source: two processes with the same digest compute the same answers
    from the same inputs."""
    from esba.derive.provenance import source_hash

    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256(source_hash().encode())
    for path in sorted(p for package in COMPUTING_PACKAGES for p in (root / package).rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _fingerprint() -> dict[str, str]:
    import casadi

    return {"esba": code_digest(), "casadi": casadi.__version__, "host": socket.gethostname()}


@dataclass(frozen=True)
class ModelKey:
    """Which model a chunk needs, and which esba must solve it: plain values that travel with
    every task, so that a worker builds the model itself (:func:`esba.model.generated.load_model`).

    Attributes
    ----------
    n : int
    effects : str
        The effect set's spec (``"air,axial,radial,fibres,payload"``).
    variant : str
    code : str
        :func:`code_digest` of the client.
    """

    n: int
    effects: str
    variant: str
    code: str

    @classmethod
    def of(cls, scene) -> ModelKey:
        """The key of a scene's model."""
        return cls(scene.segments, scene.effects.spec(), scene.variant, code_digest())

    def check(self) -> None:
        """On the worker: refuse a different esba, then load the model (once per process)."""
        if self in _LOADED:
            return
        mine = code_digest()
        if mine != self.code:
            raise DistributedError(
                f"worker on {socket.gethostname()} (pid {os.getpid()}) runs another esba or derivation "
                f"(code {mine}, the client's {self.code}): install the same esba on the workers"
            )
        from esba.model.generated import load_model

        load_model(self.n, self.effects, self.variant)
        _LOADED.add(self)


_LOADED: set[ModelKey] = set()


def run_task(key: ModelKey, fn: Callable[..., Any], *args: Any) -> Any:
    """One chunk: check ``key`` (loading the model once per process), then ``fn(*args)``, one at a
    time per process (CasADi's nlpsol is not thread-safe)."""
    with _TASK_LOCK:
        key.check()
        return fn(*args)


# ---------------------------------------------------------------------------------------------
# runners


class SerialRunner:
    """Chunks one after the other in this process."""

    workers = 1
    description = "in this process"

    def map_ordered(self, fn: Callable[..., Any], args: Iterable[tuple], done: Callable[[int], None] | None = None) -> Iterator[Any]:
        """``fn(*a)`` for each ``a`` of ``args``, in order; ``done(i)`` after chunk i is solved."""
        for i, a in enumerate(args):
            with interrupts_raised():  # Ctrl-C inside CasADi may surface as a SystemError
                result = fn(*a)
            if done is not None:
                done(i)
            yield result


class DaskRunner:
    """Chunks on a ``dask.distributed`` cluster, handed back in chunk order.

    Parameters
    ----------
    client : distributed.Client
    description : str
        Where the chunks run, for reports (``"on a local Dask cluster of 2 worker processes"``).
    window : int, optional
        Chunks in flight or waiting to be handed back (default :data:`WINDOW_PER_WORKER` per worker).
    """

    def __init__(self, client, description: str, window: int | None = None, stall_s: float = STALL_S) -> None:
        self.client = client
        self.description = description
        self.window = window if window is not None else WINDOW_PER_WORKER * max(1, self.workers)
        self.stall_s = stall_s

    @property
    def workers(self) -> int:
        """Worker processes of the cluster now."""
        return len(self.client.scheduler_info().get("workers", {}))

    def map_ordered(self, fn: Callable[..., Any], args: Iterable[tuple], done: Callable[[int], None] | None = None) -> Iterator[Any]:
        """``fn(*a)`` for each ``a`` of ``args`` on the cluster, yielded in order; ``done(i)`` as chunk i finishes.

        A chunk whose worker dies is run again by the scheduler (up to Dask's
        ``distributed.scheduler.allowed-failures``); each chunk's result is taken once. Leaving
        the generator early cancels the chunks still queued.

        Raises
        ------
        StudyStopped
            when a chunk's worker died every time it was started, or the connection to the
            scheduler was lost (the chunks handed back before stay handed back).
        """
        import dask
        from distributed import KilledWorker, as_completed

        token = uuid.uuid4().hex[:12]
        items = enumerate(args)
        pending: dict[str, tuple[int, Any]] = {}  # key -> (chunk index, future)
        ready: dict[int, Any] = {}
        queue = as_completed()
        nxt = 0
        exhausted = False

        def fill() -> None:
            nonlocal exhausted
            while not exhausted and len(pending) + len(ready) < self.window:
                item = next(items, None)
                if item is None:
                    exhausted = True
                    return
                i, a = item
                fut = self.client.submit(fn, *a, key=f"esba-chunk-{token}-{i}", pure=False)
                pending[fut.key] = (i, fut)
                queue.add(fut)

        try:
            fill()
            while pending or ready:
                if nxt in ready:
                    yield ready.pop(nxt)
                    nxt += 1
                    fill()
                    continue
                fut = self._next_done(queue, pending)
                i, _ = pending.pop(fut.key)
                try:
                    ready[i] = fut.result()
                except KilledWorker:
                    tries = dask.config.get("distributed.scheduler.allowed-failures") + 1
                    raise StudyStopped(f"chunk {i} was started {tries} times and each time its worker process died (out of memory?): the study stops") from None
                except CancelledError as exc:
                    raise StudyStopped(self._lost(i, str(getattr(exc, "reason", "") or ""))) from None
                except OSError:
                    if fut.status == "error":
                        raise  # the chunk itself raised it on its worker
                    raise StudyStopped(self._lost(i, "connection-lost")) from None  # its result could not be fetched
                fut.release()
                if done is not None:
                    done(i)
        finally:
            if pending and self.client.status == "running":
                try:
                    self.client.cancel([f for _, f in pending.values()])
                except Exception:  # noqa: BLE001 - the cluster is going away; nothing left to cancel there
                    pass

    def _next_done(self, queue, pending: dict[str, tuple[int, Any]]):
        """The next chunk to finish; :class:`StudyStopped` when none finishes and no worker runs
        any of them for :attr:`stall_s` seconds (see :data:`STALL_S`)."""
        quiet_since = last_look = time.monotonic()
        while not queue.has_ready():
            time.sleep(POLL_S)
            now = time.monotonic()
            if now - last_look < LOOK_S:
                continue
            last_look = now
            if self._running(pending):
                quiet_since = now
            elif now - quiet_since > self.stall_s:
                first = min(i for i, _ in pending.values())
                address = getattr(getattr(self.client, "scheduler", None), "address", None) or "?"
                raise StudyStopped(
                    f"chunk {first} waited {self.stall_s:g} s on the Dask cluster at {address} with no worker running it or any other "
                    f"chunk of the study ({self.workers} worker processes connected): the study stops"
                )
        return next(queue)

    def _running(self, pending: dict[str, tuple[int, Any]]) -> bool:
        """Whether the scheduler has a worker running one of the chunks ``pending`` (True when it cannot tell)."""
        try:
            processing = self.client.processing()
        except Exception:  # noqa: BLE001 - a lost connection is the result's to report, as it does
            return True
        return any(str(k) in pending for keys in processing.values() for k in keys)

    def _lost(self, i: int, reason: str) -> str:
        """Why chunk i did not come back: the connection to the scheduler was lost, or it was cancelled."""
        address = getattr(getattr(self.client, "scheduler", None), "address", None) or "?"
        if "connection-lost" in reason or self.client.status != "running":
            return f"the connection to the Dask scheduler at {address} was lost while chunk {i} was being solved (the scheduler stopped?): the study stops"
        return f"chunk {i} was cancelled on the Dask cluster at {address} ({reason or 'by another client?'}): the study stops"


@contextmanager
def open_runner(workers: int | None = None, scheduler: str | None = None, timeout: float = 10.0) -> Iterator[SerialRunner | DaskRunner]:
    """The runner of a study: in this process (neither given), a local cluster of ``workers``
    processes, or the cluster of the scheduler at ``scheduler``; closed on leaving the block.

    While a Dask runner is open, the ``distributed`` loggers of this process are silenced (esba
    reports what matters itself; ``ESBA_DEBUG=1`` keeps them). A Ctrl-C while the cluster starts
    or closes is held until that step is over, then raised as :class:`KeyboardInterrupt`; after
    an interrupt the local cluster's worker processes are stopped at once, not waited for.

    Raises
    ------
    DistributedError
        for both given, Dask missing, an address where no Dask scheduler answers within
        ``timeout`` s (nothing, or another service), a scheduler with no worker by then, or
        workers with another esba (:func:`code_digest`) or CasADi.
    """
    if workers is None and scheduler is None:
        yield SerialRunner()
        return
    if workers is not None and scheduler is not None:
        raise DistributedError("--workers N starts a local cluster and --scheduler ADDRESS uses an existing one: give one of the two")
    require_dask("--workers" if workers is not None else "--scheduler")
    with _quiet_dask_logs():
        client, cluster, description = _connect(workers, scheduler, timeout)
        interrupted = False
        try:
            yield DaskRunner(client, description)
        except KeyboardInterrupt:
            interrupted = True
            raise
        finally:
            _close(client, cluster, hurry=interrupted)


def _connect(workers: int | None, scheduler: str | None, timeout: float):
    """The client (and the local cluster) of :func:`open_runner`, checked; closed again on any failure."""
    from distributed import Client, LocalCluster

    cluster = client = None
    if workers is not None:
        workers = check_workers(workers)
        description = f"on a local Dask cluster of {workers} worker process{'es' if workers > 1 else ''} (1 thread each)"
    else:
        scheduler = check_address(scheduler)
        description = f"on the Dask cluster at {scheduler}"
        _probe_scheduler(scheduler, timeout)  # before Dask's client, which waits for ever on a service that is not Dask
    try:
        if workers is not None:
            with _sigint_held():  # a cluster half started could not be closed
                cluster = LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1", silence_logs=logging.CRITICAL,
                    dashboard_address=None, scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},  # no dashboard, no fixed port
                )
                client = Client(cluster)
                _check_cluster(client)
        else:
            with _sigint_held():  # nor a client half connected
                client = _scheduler_client(scheduler, timeout)
            try:
                client.wait_for_workers(1, timeout=timeout)  # as long as the user asked: Ctrl-C is not held here
            except (OSError, TimeoutError):
                raise DistributedError(f"--scheduler {scheduler!r}: the scheduler has no worker after {timeout:g} s: start some (dask worker {scheduler})") from None
            _check_cluster(client)
    except BaseException as exc:
        _close(client, cluster, hurry=isinstance(exc, KeyboardInterrupt))
        raise
    return client, cluster, description


def _scheduler_client(scheduler: str, timeout: float):
    """A client of the scheduler at ``scheduler`` (that answered :func:`_probe_scheduler` a moment ago)."""
    from distributed import Client

    try:
        return Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError, MemoryError, ValueError):
        raise DistributedError(f"--scheduler {scheduler!r}: no Dask scheduler answered within {timeout:g} s") from None


def _probe_scheduler(address: str, timeout: float) -> None:
    """Ask what answers at ``address`` who it is (Dask's ``identity``), within ``timeout`` seconds.

    Dask's own client waits without limit for a service that accepts the connection but does not
    answer as Dask does, and allocates whatever size a service that speaks first (an SSH banner)
    seems to announce; this probe runs in a thread of its own with a hard deadline and turns every
    such answer into one :class:`DistributedError`.
    """
    import asyncio

    from distributed.comm import connect
    from distributed.comm.core import CommClosedError
    from distributed.security import Security

    async def identity():
        comm = await connect(address, timeout=timeout, **Security().get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            reply = await comm.read()
            await comm.write({"op": "close", "reply": False})
            return reply
        finally:
            comm.abort()

    outcome: dict[str, Any] = {}

    def probe() -> None:
        try:
            outcome["reply"] = asyncio.run(asyncio.wait_for(identity(), timeout))
        except BaseException as exc:  # noqa: BLE001 - every way of failing is reported below
            outcome["error"] = exc

    thread = threading.Thread(target=probe, name="esba scheduler probe", daemon=True)
    thread.start()
    thread.join(timeout + 5.0)  # the probe keeps its own deadline; this one is for a stuck name lookup
    flag = f"--scheduler {address!r}"
    if "reply" not in outcome:
        exc = outcome.get("error")
        if exc is None or isinstance(exc, (asyncio.TimeoutError, TimeoutError)) or (isinstance(exc, OSError) and not isinstance(exc, CommClosedError)):
            raise DistributedError(f"{flag}: no Dask scheduler answered within {timeout:g} s")
        raise DistributedError(f"{flag}: is not a Dask scheduler (the service there does not speak Dask's protocol)")
    reply = outcome["reply"]
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind != "Scheduler":
        raise DistributedError(f"{flag}: is not a Dask scheduler" + (f" but a Dask {kind}" if isinstance(kind, str) and kind.isidentifier() else ""))


def _close(client, cluster, hurry: bool = False) -> None:
    """Close the client and the local cluster. With ``hurry`` (after an interrupt) each waits a
    few seconds at most, and the local cluster's worker processes still alive then are killed.
    A Ctrl-C while closing is held until the cluster is closed, then raised."""
    with _sigint_held():
        processes = _worker_processes(cluster) if hurry and cluster is not None else []
        if client is not None:
            try:
                client.close(timeout=2 if hurry else None)
            except Exception:  # noqa: BLE001 - a client whose scheduler is gone closes with errors
                pass
        if cluster is not None:
            try:
                cluster.close(timeout=3 if hurry else None)
            except Exception:  # noqa: BLE001 - workers that do not answer are killed below
                pass
        for process in processes:
            try:
                if process.is_alive():
                    process.kill()
            except (OSError, ValueError, AssertionError):  # pragma: no cover - gone meanwhile
                pass


def _worker_processes(cluster) -> list:
    """The ``multiprocessing.Process`` of each worker of a local cluster that has one (Dask's
    nanny -> worker process -> process; an empty list where Dask keeps them otherwise)."""
    out = []
    for nanny in list(getattr(cluster, "workers", {}).values()):
        process = getattr(getattr(getattr(nanny, "process", None), "process", None), "_process", None)
        if process is not None and hasattr(process, "kill") and hasattr(process, "is_alive"):
            out.append(process)
    return out


@contextmanager
def _quiet_dask_logs() -> Iterator[None]:
    """Silence the ``distributed`` loggers of this process inside the block (not with ``ESBA_DEBUG``).

    A scheduler lost, a worker killed and its chunk run again, a cluster closed after Ctrl-C: Dask
    logs each as ERROR lines with tracebacks, and esba says what happened in one line itself.
    """
    if os.environ.get("ESBA_DEBUG"):
        yield
        return
    names = ["distributed", *sorted(n for n in list(logging.root.manager.loggerDict) if n.startswith("distributed."))]
    saved = [(logging.getLogger(n), logging.getLogger(n).level) for n in names]
    for logger, level in saved:
        if level != logging.NOTSET or logger.name == "distributed":
            logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in saved:
            logger.setLevel(level)


@contextmanager
def _sigint_held() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT) inside the block and raise it as :class:`KeyboardInterrupt` at its end.

    A cluster half started or half closed cannot be cleaned up, so an interrupt waits for the
    step to finish. SIGINT is also blocked in this thread inside the block: the threads started
    in it, and the worker processes they start, inherit the blocked signal, so the terminal's
    Ctrl-C reaches only this process, which stops the study and closes the cluster, instead of
    every worker printing its own KeyboardInterrupt.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if hasattr(signal, "pthread_sigmask"):
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()  # started later, it would unblock SIGINT in this thread (bpo-33613)
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    mask = getattr(signal, "pthread_sigmask", None)
    blocked = mask(signal.SIG_BLOCK, {signal.SIGINT}) if mask is not None else None
    try:
        yield
    finally:
        if mask is not None:
            mask(signal.SIG_SETMASK, blocked)  # a SIGINT that waited is delivered now ...
        _handle_signals()  # ... and its handler, the one above, runs here
        signal.signal(signal.SIGINT, previous)
        if caught:
            raise KeyboardInterrupt


def _handle_signals() -> None:
    """A Python-level call: the interpreter runs pending signal handlers before it returns."""


def _check_cluster(client) -> None:
    """Every worker runs this process's esba and CasADi."""
    mine = _fingerprint()
    try:
        theirs = client.run(_fingerprint)
    except ImportError as exc:
        raise DistributedError(f"a Dask worker cannot import esba ({exc}): install the same esba on the workers") from None
    for address, fp in sorted(theirs.items()):
        for what in ("esba", "casadi"):
            if fp[what] != mine[what]:
                raise DistributedError(
                    f"Dask worker {address} on {fp['host']} has another {what} ({fp[what]}; this process {mine[what]}): "
                    "install the same esba on the workers"
                )
