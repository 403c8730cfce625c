"""Studies on Dask (esba.studies.distributed, esba.studies.chunks, esba.studies.sweep_runner, esba.studies.monte_carlo): the same rows as
in this process, a killed worker's chunk solved again, resuming an interrupted study, and the
flags' one-line errors.

The Dask tests use a local cluster of 2 worker processes (one thread each), as CI does.
"""

from __future__ import annotations

import csv
import errno
import importlib.util
import io
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from esba.calibration.uncertainty import MonteCarloOptions, parse_sigma, resolve_sigmas
from esba.cli import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, main
from esba.model.scene import MAIN_JOB, Payload, Scene
from esba.statics.batch import BatchOptions, compiler
from esba.studies.chunks import StudyError, StudyFile, StudyStopped, read_header, sidecar
from esba.studies.distributed import (
    DASK_EXTRA,
    DaskRunner,
    DistributedError,
    SerialRunner,
    open_runner,
)
from esba.studies.monte_carlo import monte_carlo, monte_carlo_study
from esba.studies.sweep import plan_sweep, sweep
from esba.studies.sweep_runner import read_rows, sweep_study
from tests.studies.runners import StopAfter

#: Every test here may start a cluster or a process: one that hangs (a wait on Dask, a process that
#: does not end) fails with pytest-timeout's message after this long, seconds, instead of holding
#: the suite (the tests take seconds to a minute each, on a busy machine a few).
pytestmark = pytest.mark.timeout(600)

#: The tests that start a cluster or parse cluster flags need the extra (the test extra installs it);
#: the missing-extra test runs either way.
needs_dask = pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="dask.distributed is not installed (pip install -e '.[test]' installs it)")

INTERPRETED = BatchOptions(compile="never")

#: A grid with every kind of row: infeasible designs (r2 + d >= r1), points the fast path answers,
#: its finer retry, and pseudo-arclength continuation (large payloads against the bend).
BASE = Scene(payloads=(Payload(1.0, 90.0),))
GRID = dict(pressure=[0.0, 0.1, 0.2, 0.3], payload=[0.0, 2.0, 6.0], payload_angle=[90.0, 180.0], r2=[3.0, 4.5], d=[2.0, 4.0])


def _methods(result) -> set[str]:
    return set(result.method.tolist())


@pytest.fixture(scope="module")
def reference():
    """The grid solved in this process, in one batch (the in-process sweep)."""
    ref = sweep(BASE, options=INTERPRETED, **GRID)
    assert {"newton", "continuation"} <= _methods(ref) and ref.counts()["infeasible"] > 0
    return ref


@pytest.fixture(scope="module")
def cluster():
    with open_runner(workers=2) as runner:
        assert runner.workers == 2
        yield runner


# ---------------------------------------------------------------------------------------------
# the same answers, element for element


@needs_dask
def test_sweep_on_two_workers_is_the_in_process_sweep(cluster, reference):
    study = sweep_study(plan_sweep(BASE, **GRID), INTERPRETED, runner=cluster, chunk=7)
    got = study.result
    assert study.chunks == 14 and study.workers == 2 and "2 worker processes" in study.runner
    assert got.rows() == reference.rows()  # same order, statuses, messages, notes
    for name in ("theta", "tip", "pressure"):
        np.testing.assert_array_equal(getattr(got, name), getattr(reference, name))  # bitwise, NaN where NaN
    assert got.backend == reference.backend


@needs_dask
@pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, gcc, cc) on this machine")
def test_compiled_sweep_on_two_workers_is_bitwise_the_in_process_one(cluster):
    options = BatchOptions(compile="always")
    ref = sweep(BASE, options=options, **GRID)
    study = sweep_study(plan_sweep(BASE, **GRID), options, runner=cluster, chunk=20)
    assert study.backend.startswith("compiled C") and study.result.rows() == ref.rows()
    np.testing.assert_array_equal(study.result.theta, ref.theta)


@needs_dask
def test_streamed_file_is_the_in_process_file(cluster, reference, tmp_path):
    """One file format however the sweep ran: the same CSV (column names first) and the same
    metadata beside it, from a study on Dask and from a sweep in this process."""
    out = tmp_path / "grid.csv"
    study = sweep_study(plan_sweep(BASE, **GRID), INTERPRETED, runner=cluster, chunk=9, out=out)
    header = read_header(out)
    assert header["kind"] == "sweep" and header["hash"] == study.hash and header["rows"] == len(reference.status)
    assert header["settings"]["compile"] == "never"
    assert out.read_text(encoding="utf-8") == reference.to_csv()
    here = reference.write(tmp_path / "here.csv")
    assert here.read_bytes() == out.read_bytes()
    assert sidecar(here).read_bytes() == sidecar(out).read_bytes()
    assert read_rows(out) == reference.rows() and study.counts == reference.counts() and study.result is None


@needs_dask
def test_monte_carlo_on_two_workers_is_the_in_process_one(cluster):
    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=5%"), parse_sigma("s1=±0.01")])  # about half the samples invalid
    opts = MonteCarloOptions(samples=240, seed=3, chunk=50)
    here = monte_carlo(MAIN_JOB, sig, opts)
    there = monte_carlo(MAIN_JOB, sig, opts, runner=cluster)
    assert 0 < here.counts["invalid"] < 240
    for name in ("samples", "code", "theta", "tip", "total_angle"):
        np.testing.assert_array_equal(getattr(there, name), getattr(here, name))
    assert there.to_dict() == here.to_dict()


@needs_dask
@pytest.mark.slow
@pytest.mark.ci
def test_a_larger_compiled_study_on_two_workers(cluster):
    """n = 8, 3000 points on the compiled batch path (when a compiler is found) in chunks of 250,
    and 2000 Monte Carlo samples: element for element the in-process answers."""
    base = Scene(segments=8, payloads=(Payload(1.0, 90.0),))
    grid = dict(pressure=list(np.linspace(0.0, 0.25, 30)), payload=list(np.linspace(0.0, 4.0, 10)), payload_angle=list(np.linspace(0.0, 180.0, 10)))
    ref = sweep(base, **grid)  # compile="auto": decided once for the grid, as the study decides it
    study = sweep_study(plan_sweep(base, **grid), runner=cluster, chunk=250)
    assert study.backend == ref.backend and len(ref.status) == 3000
    assert study.result.rows() == ref.rows()
    np.testing.assert_array_equal(study.result.theta, ref.theta)
    scene = MAIN_JOB.replace(segments=8)
    sig = resolve_sigmas(scene, [parse_sigma("E=10%"), parse_sigma("r2=±0.2"), parse_sigma("Omega1=±5")])
    opts = MonteCarloOptions(samples=2000, seed=11, chunk=300)
    here, there = monte_carlo(scene, sig, opts), monte_carlo(scene, sig, opts, runner=cluster)
    for name in ("code", "theta", "tip"):
        np.testing.assert_array_equal(getattr(there, name), getattr(here, name))


@needs_dask
@pytest.mark.slow
def test_a_study_of_twenty_thousand_points_at_n16_on_two_workers(cluster, tmp_path):
    """A design study at full scale (n = 16), 20 000 points streamed to a file in chunks of 1000."""
    base = Scene(segments=16, payloads=(Payload(1.0, 90.0),))
    grid = dict(pressure=list(np.linspace(0.0, 0.2, 100)), payload=list(np.linspace(0.0, 2.0, 20)), r2=[2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0, 6.5, 7.0])
    out = tmp_path / "big.csv"
    study = sweep_study(plan_sweep(base, **grid), runner=cluster, out=out)
    ref = sweep(base, **grid)
    assert study.chunks == 20 and read_rows(out) == ref.rows()


# ---------------------------------------------------------------------------------------------
# a worker that dies


def _kill_once(marker: str, fn, *args):
    """Kill this worker process the first time any chunk runs; later calls solve the chunk."""
    try:
        fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return fn(*args)
    os.write(fd, str(os.getpid()).encode())
    os.close(fd)
    os._exit(1)


class _KillingRunner(DaskRunner):
    """A Dask runner whose first chunk to start kills its worker process."""

    def __init__(self, runner: DaskRunner, marker) -> None:
        super().__init__(runner.client, runner.description)
        self.marker = str(marker)

    def map_ordered(self, fn, args, done=None):
        return super().map_ordered(_kill_once, ((self.marker, fn, *a) for a in args), done)


@needs_dask
def test_a_killed_workers_chunk_is_solved_again_and_every_row_written_once(capfd, reference, tmp_path):
    marker = tmp_path / "killed"
    out = tmp_path / "grid.csv"
    capfd.readouterr()
    with open_runner(workers=2) as runner:
        pids = set(runner.client.run(os.getpid).values())
        study = sweep_study(plan_sweep(BASE, **GRID), INTERPRETED, runner=_KillingRunner(runner, marker), chunk=8, out=out)
    assert marker.exists() and int(marker.read_text()) in pids  # a worker process did die mid-study
    assert study.chunks == 12
    assert read_rows(out) == reference.rows()  # nothing lost, nothing twice, in order
    assert "distributed." not in capfd.readouterr().err  # Dask's log lines about it ("Couldn't gather keys", ...) are silenced


# ---------------------------------------------------------------------------------------------
# resuming


class _Interrupted(Exception):
    pass


@needs_dask
def test_an_interrupted_study_resumes_from_its_file(cluster, reference, tmp_path):
    out = tmp_path / "grid.csv"
    plan = plan_sweep(BASE, **GRID)
    with pytest.raises(KeyboardInterrupt):
        sweep_study(plan, INTERPRETED, runner=StopAfter(cluster, 3), chunk=10, out=out)
    assert len(read_rows(out)) == 30  # three whole chunks on disk
    # the last chunk was cut short while being written: its broken tail row is dropped
    text = out.read_text(encoding="utf-8")
    out.write_text(text + text.splitlines(keepends=True)[-1][:25], encoding="utf-8")
    again = sweep_study(plan, INTERPRETED, runner=SerialRunner(), chunk=13, out=out, resume=True)
    assert again.resumed_from == 30 and again.chunks == 6  # (96 - 30) points in chunks of 13
    assert read_rows(out) == reference.rows()
    assert again.counts == reference.counts()
    # resuming a finished study solves nothing
    done = sweep_study(plan, INTERPRETED, runner=cluster, out=out, resume=True)
    assert done.chunks == 0 and done.resumed_from == len(reference.status) and read_rows(out) == reference.rows()


@needs_dask
def test_resume_refuses_another_studys_file(tmp_path):
    out = tmp_path / "grid.csv"
    plan = plan_sweep(Scene(pressure=0.1), payload=[0.0, 1.0, 2.0])
    sweep_study(plan, INTERPRETED, out=out, chunk=2)
    other = plan_sweep(Scene(pressure=0.1), payload=[0.0, 1.0, 3.0])
    with pytest.raises(StudyError, match=r"another study .* differs in plan\.axes\.payload"):
        sweep_study(other, INTERPRETED, out=out, resume=True)
    with pytest.raises(StudyError, match=r"differs in batch\.load_steps"):
        sweep_study(plan, BatchOptions(compile="never", load_steps=9), out=out, resume=True)
    here = tmp_path / "here.csv"  # a sweep in this process writes the same study file: resuming it solves nothing
    sweep(Scene(pressure=0.1), payload=[0.0, 1.0, 2.0], options=INTERPRETED).write(here)
    assert sweep_study(plan, INTERPRETED, out=here, resume=True).chunks == 0
    sidecar(here).unlink()
    with pytest.raises(StudyError, match="not a study file"):
        sweep_study(plan, INTERPRETED, out=here, resume=True)
    lines = out.read_text(encoding="utf-8").splitlines(keepends=True)
    out.write_text("".join(lines[:2]) + "1,2,3\n" + "".join(lines[2:]), encoding="utf-8")
    with pytest.raises(StudyError, match="row 2 has 3 cells"):
        sweep_study(plan, INTERPRETED, out=out, resume=True)


@needs_dask
def test_monte_carlo_streams_its_samples_and_resumes(cluster, tmp_path):
    sig = resolve_sigmas(MAIN_JOB, [parse_sigma("E=5%")])
    opts = MonteCarloOptions(samples=120, seed=1, chunk=25)
    whole = monte_carlo(MAIN_JOB, sig, opts)
    out = tmp_path / "mc.csv"
    with pytest.raises(KeyboardInterrupt):
        monte_carlo_study(MAIN_JOB, sig, opts, runner=StopAfter(cluster, 2), out=out)
    mc, info = monte_carlo_study(MAIN_JOB, sig, opts, runner=cluster, out=out, resume=True)
    assert info["resumed_from_sample"] == 50
    for name in ("code", "theta", "tip", "total_angle"):
        np.testing.assert_array_equal(getattr(mc, name), getattr(whole, name))
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert [int(r["sample"]) for r in rows] == list(range(120)) and rows[0]["outcome"] == "ok"
    with pytest.raises(StudyError, match="another study"):
        monte_carlo_study(MAIN_JOB, sig, MonteCarloOptions(samples=120, seed=2), out=out, resume=True)


# ---------------------------------------------------------------------------------------------
# the command line


def _one_line_error(capsys, argv, needle):
    assert main(argv) == EXIT_USAGE
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("esba: error:") and needle in err, err
    return err


@needs_dask
def test_cli_sweep_on_workers_writes_the_in_process_rows(capsys, tmp_path):
    grid = ["--pressure", "0:0.2:4", "--payload", "0,2", "--r2", "3,5", "--no-compile", "--no-progress"]
    here, there = tmp_path / "here.csv", tmp_path / "there.csv"
    assert main(["sweep", *grid, "--out", str(here)]) == EXIT_OK
    assert main(["sweep", *grid, "--workers", "2", "--chunk", "5", "--out", str(there)]) == EXIT_OK
    out = capsys.readouterr().out
    assert "study: 4 chunks of up to 5 points on a local Dask cluster of 2 worker processes" in out
    assert there.read_text() == here.read_text()
    assert main(["sweep", *grid, "--json"]) == EXIT_OK
    alone = json.loads(capsys.readouterr().out)
    assert main(["sweep", *grid, "--workers", "2", "--json"]) == EXIT_OK  # rows gathered in memory
    gathered = json.loads(capsys.readouterr().out)
    assert main(["sweep", *grid, "--workers", "2", "--out", str(there), "--json"]) == EXIT_OK  # rows in the file only
    out, err = capsys.readouterr()
    streamed = json.loads(out)
    assert f"esba: {there} held 16 rows of this study; starting over (give --resume to continue it)\n" in err
    assert gathered["rows"] == alone["rows"] == read_rows(there) and len(alone["rows"]) == 16 and "rows" not in streamed
    assert gathered["study"]["workers"] == streamed["study"]["workers"] == 2 and streamed["out"] == str(there)
    assert streamed["counts"] == gathered["counts"] == alone["counts"]


@needs_dask
def test_cli_monte_carlo_on_workers(capsys):
    argv = ["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "100", "--json"]
    assert main(argv) == EXIT_OK
    here = json.loads(capsys.readouterr().out)
    assert main([*argv, "--workers", "2", "--mc-chunk", "30"]) == EXIT_OK
    there = json.loads(capsys.readouterr().out)
    study = there["monte_carlo"].pop("study")
    assert (there["monte_carlo"].pop("chunk"), here["monte_carlo"].pop("chunk")) == (30, 2500)
    assert there["monte_carlo"] == here["monte_carlo"] and there["agreement"] == here["agreement"]
    assert study["workers"] == 2


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["sweep", "--pressure", "0.1", "--workers", "0"], "argument --workers: '0': expected a whole number of worker processes from 1 to"),
        (["sweep", "--pressure", "0.1", "--workers", "two"], "argument --workers: 'two'"),
        (["sweep", "--pressure", "0.1", "--workers", "100000"], "for more, start a cluster and give --scheduler ADDRESS"),
        (["sweep", "--pressure", "0.1", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "give one of the two"),
        (["sweep", "--pressure", "0.1", "--scheduler", "not an address"], "argument --scheduler: 'not an address': expected a Dask scheduler address"),
        (["sweep", "--pressure", "0.1", "--scheduler", "tcp://host:99999"], "tcp://HOST:PORT"),
        (["sweep", "--pressure", "0.1", "--scheduler", "tcp://127.0.0.1:8786", "--connect-timeout", "0"], "argument --connect-timeout: '0'"),
        (["sweep", "--pressure", "0.1", "--chunk", "0"], "argument --chunk: '0': expected a whole number of points per chunk"),
        (["sweep", "--pressure", "0.1", "--resume"], "--resume continues a study from the CSV file"),
        (["sweep", "--pressure", "0.1", "--resume", "--out", "x.json"], "give --out FILE.csv"),
        (["sweep", "--pressure", "0.1", "--workers", "2", "--out", "x.txt"], "--out 'x.txt': '.txt'; expected a file ending in .csv, .json"),
        (["sweep", "--pressure", "0.1", "--workers", "2", "--out", "x.csv", "--plot", "x.png"], "--plot needs every row in memory"),
        (["sweep", "--fig12", "f.png", "--workers", "2"], "--fig12 draws its own small grid"),
        (["solve", "--no-plot", "--workers", "2"], "give --monte-carlo N"),
        (["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20", "--resume"], "give --mc-out FILE.csv"),
        (["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20", "--mc-out", "x.json"], "argument --mc-out"),
        (["bench", "scaling", "--points", "5"], "argument --points: points=5: expected a whole number from 20 to 200000"),
        (["bench", "scaling", "--repeat", "0"], "argument --repeat: repeat=0: expected a whole number from 1 to 50"),
        (["bench", "scaling", "--workers", "1", "--scheduler", "tcp://127.0.0.1:8786"], "give one of the two"),
        (["bench", "scaling", "--points", "1000000"], "points=1000000: expected a whole number from 20 to 200000"),
        (["bench", "scaling", "--points", "200000", "-n", "256"], "would take about"),
        (["bench", "scaling", "--connect-timeout", "1"], "--connect-timeout is the wait for --scheduler ADDRESS"),
        (["sweep", "--pressure", "0.1", "--workers", "1", "--connect-timeout", "1"], "--connect-timeout is the wait for --scheduler ADDRESS"),
        # every row gathered in memory: the same bound as in this process, before a cluster starts
        (["sweep", "-n", "256", "--pressure", "0:0.2:20000", "--workers", "1"], "the sweep of 20000 equilibria at n = 256 would take about 9.9 GiB"),
    ],
)
@needs_dask
def test_cli_bad_cluster_flags_are_one_line_exit_2(capsys, argv, needle):
    _one_line_error(capsys, argv, needle)


@needs_dask
def test_cli_unreachable_scheduler_is_one_line_exit_2(capsys):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    _one_line_error(capsys, ["sweep", "--pressure", "0.1", "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "1"],
                    f"--scheduler 'tcp://127.0.0.1:{port}': no Dask scheduler answered within 1 s")


@needs_dask
def test_cli_resume_of_a_mismatched_file_is_one_line_exit_2(capsys, tmp_path):
    out = tmp_path / "s.csv"
    assert main(["sweep", "--pressure", "0,0.1", "--no-compile", "--no-progress", "--resume", "--out", str(out)]) == EXIT_OK
    capsys.readouterr()
    _one_line_error(capsys, ["sweep", "--pressure", "0,0.2", "--no-compile", "--no-progress", "--resume", "--out", str(out)], "belongs to another study")
    out.write_text("pressure_mpa\n0.1\n", encoding="utf-8")
    sidecar(out).unlink()
    _one_line_error(capsys, ["sweep", "--pressure", "0,0.1", "--no-progress", "--resume", "--out", str(out)], "not a study file")


def test_missing_dask_is_one_line_that_names_the_extra(capsys, monkeypatch):
    """Without the extra (simulated: dask.distributed cannot be imported) --workers and --scheduler say how to get it."""
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(DistributedError, match=r'needs Dask, an optional extra of esba: pip install "esba\[dask\]"'):
        with open_runner(workers=2):
            pass
    for argv in (["sweep", "--pressure", "0.1", "--workers", "2"],
                 ["sweep", "--pressure", "0.1", "--scheduler", "tcp://127.0.0.1:8786"],
                 ["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20", "--workers", "2"]):
        err = _one_line_error(capsys, argv, DASK_EXTRA)
        assert ("--workers" in err) != ("--scheduler" in err)
    # without the flags, everything runs in this process as before
    assert main(["sweep", "--pressure", "0.1", "--no-compile", "--no-progress"]) == EXIT_OK


def _always_kill(fn, *args):
    os._exit(1)


class _AlwaysKillingRunner(DaskRunner):
    def __init__(self, runner: DaskRunner) -> None:
        super().__init__(runner.client, runner.description)

    def map_ordered(self, fn, args, done=None):
        return super().map_ordered(_always_kill, ((fn, *a) for a in args), done)


def _killing_cluster(workers=None, scheduler=None, timeout=10.0):
    """A stand-in for esba.studies.distributed.open_runner (for the CLI): a fresh local cluster of
    two workers whose every chunk kills its worker."""
    return _fresh_killing()


@contextmanager
def _fresh_killing():
    with open_runner(workers=2) as runner:
        yield _AlwaysKillingRunner(runner)


@needs_dask
@pytest.mark.timeout(900)
def test_a_chunk_that_always_kills_its_worker_stops_the_study_with_a_message(capsys, monkeypatch, tmp_path):
    # Deterministic, whatever the machine's load: one chunk, two workers, and a chunk given up after
    # its second worker died (allowed-failures 1): no worker has to come back for the study to stop.
    # (With Dask's default of 3 failures, the nannies must start workers again twice; on a busy
    # machine they may not, and the study then stops after STALL_S with no worker left: the
    # test of that is the next one.) Each run has a fresh cluster: the one before has no worker left.
    import dask
    import distributed  # noqa: F401 - its configuration's defaults

    monkeypatch.setitem(dask.config.config["distributed"]["scheduler"], "allowed-failures", 1)  # restored after the test
    out = tmp_path / "grid.csv"
    grid = ["sweep", "--pressure", "0:0.3:40", "--no-compile", "--no-progress", "--chunk", "50", "--workers", "2"]
    # the model the command needs is made first (in this process, one point): on a fresh cache it
    # would be generated on demand, and say so on stderr, whatever the test's order
    assert main(["sweep", "--pressure", "0.1", "--no-compile", "--no-progress"]) == EXIT_OK
    capsys.readouterr()
    with _fresh_killing() as runner:
        with pytest.raises(StudyStopped, match=r"chunk 0 was started 2 times and each time its worker process died") as info:
            sweep_study(plan_sweep(BASE, **GRID), INTERPRETED, runner=runner, chunk=100, out=out)
        assert not isinstance(info.value, ValueError)  # a failure at run time, not bad input
    assert read_rows(out) == []  # the header is there, and no row: --resume starts from the first chunk
    # the command line: exit 1, and what is kept only when the rows stream to a file
    monkeypatch.setattr("esba.studies.distributed.open_runner", _killing_cluster)
    assert main(grid) == EXIT_FAILED
    out_text, err = capsys.readouterr()
    assert out_text == "" and err.count("\n") == 1 and err.startswith("esba: error: chunk 0 was started 2 times"), err
    assert "kept" not in err and "so far" not in err and "--resume" not in err, err
    assert main([*grid, "--out", str(out)]) == EXIT_FAILED
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.rstrip().endswith(f"the study stops; the rows solved so far are in {out}: rerun with --resume to go on"), err


class _NowhereClient:
    """A client whose chunks ask for a resource no worker has: the scheduler holds them and gives
    them to no worker, for ever (a stuck cluster, as a worker lost and not coming back)."""

    def __init__(self, client) -> None:
        self._client = client

    def __getattr__(self, name):
        return getattr(self._client, name)

    def submit(self, *args, **kwargs):
        return self._client.submit(*args, resources={"esba-test-nowhere": 1}, **kwargs)


@needs_dask
@pytest.mark.timeout(300)
def test_a_chunk_no_worker_runs_stops_the_study_with_a_message_not_a_hang(cluster, tmp_path):
    stuck = DaskRunner(_NowhereClient(cluster.client), cluster.description, stall_s=3.0)
    with pytest.raises(StudyStopped, match=r"chunk 0 waited 3 s on the Dask cluster at .* with no worker running it .*: the study stops"):
        sweep_study(plan_sweep(BASE, pressure=[0.1, 0.2]), INTERPRETED, runner=stuck, chunk=1, out=tmp_path / "grid.csv")
    assert read_rows(tmp_path / "grid.csv") == []


# ---------------------------------------------------------------------------------------------
# a --scheduler address where no Dask scheduler answers


@contextmanager
def _service(kind: str):
    """A TCP service on a free port of 127.0.0.1 that is not Dask: ``silent`` accepts connections
    and never answers, ``ssh`` speaks first (a banner), ``http`` is Python's HTTP server."""
    if kind == "http":
        from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

        class Quiet(BaseHTTPRequestHandler):
            def log_message(self, *args) -> None:
                pass

        server = ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        try:
            yield f"tcp://127.0.0.1:{server.server_address[1]}"
        finally:
            server.shutdown()
            server.server_close()
        return
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    listener.settimeout(0.1)
    conns, stop = [], threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                continue
            conns.append(conn)
            if kind == "ssh":
                conn.sendall(b"SSH-2.0-OpenSSH_9.6p1 Ubuntu-3ubuntu13.5\r\n")

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        stop.set()
        thread.join()
        for conn in conns:
            conn.close()
        listener.close()


@needs_dask
@pytest.mark.parametrize("kind, needle", [
    ("silent", "no Dask scheduler answered within 1 s"),
    ("http", "no Dask scheduler answered within 1 s"),  # Dask alone waits for ever
    ("ssh", "is not a Dask scheduler"),  # Dask alone reads the banner as a frame size: exabytes
])
@pytest.mark.timeout(120)  # it returns: the 1 s timeout is kept (Dask alone would wait for ever)
def test_cli_scheduler_address_of_another_service_is_one_line_exit_2(capsys, kind, needle):
    with _service(kind) as address:
        err = _one_line_error(capsys, ["sweep", "--pressure", "0.1", "--scheduler", address, "--connect-timeout", "1"], needle)
    assert err.startswith(f"esba: error: --scheduler '{address}': ")


@needs_dask
def test_cli_sweep_on_a_scheduler_address_and_a_workers_address_refused(capsys, cluster, tmp_path):
    grid = ["--pressure", "0:0.2:4", "--payload", "0,2", "--no-compile", "--no-progress"]
    here, there = tmp_path / "here.csv", tmp_path / "there.csv"
    assert main(["sweep", *grid, "--out", str(here)]) == EXIT_OK
    address = cluster.client.scheduler.address
    assert main(["sweep", *grid, "--scheduler", address, "--chunk", "3", "--out", str(there)]) == EXIT_OK
    out, err = capsys.readouterr()
    assert f"on the Dask cluster at {address}" in out and there.read_text() == here.read_text()
    assert "error" not in err and "distributed." not in err
    worker = min(cluster.client.scheduler_info()["workers"])
    _one_line_error(capsys, ["sweep", *grid, "--scheduler", worker], f"--scheduler '{worker}': is not a Dask scheduler but a Dask Worker")


# ---------------------------------------------------------------------------------------------
# a scheduler lost mid-study


def _kill_scheduler_at(pid: int, i: int, k: int, fn, *args):
    """On the worker: from chunk ``k`` on, kill the scheduler's process first."""
    if i >= k:
        os.kill(pid, signal.SIGKILL)
        time.sleep(1.0)
    return fn(*args)


@needs_dask
@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.timeout(1200)
def test_a_lost_scheduler_stops_the_study_in_one_line_and_it_resumes(capfd, monkeypatch, tmp_path):
    """A scheduler and a worker started as ``dask scheduler`` and ``dask worker`` do; the third
    chunk kills the scheduler. The command says so in one line (no Dask traceback), exit 1, and
    the rows written before resume to the in-process answer."""
    grid = ["sweep", "--pressure", "0:0.2:4", "--payload", "0,2", "--r2", "3,5", "--no-compile", "--no-progress"]
    here, out = tmp_path / "here.csv", tmp_path / "grid.csv"
    assert main([*grid, "--out", str(here)]) == EXIT_OK
    capfd.readouterr()
    file = tmp_path / "scheduler.json"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=Path(__file__).resolve().parents[2])
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                                  "--no-dashboard", "--scheduler-file", str(file)], **quiet)
    worker = None
    try:
        for _ in range(6000):  # a scheduler takes seconds to start, on a busy machine a minute or more
            if file.exists() and file.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(file.read_text())["address"]
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-dashboard"], **quiet)

        class Killing(DaskRunner):
            def map_ordered(self, fn, args, done=None):
                return super().map_ordered(_kill_scheduler_at, ((scheduler.pid, i, 2, fn, *a) for i, a in enumerate(args)), done)

        monkeypatch.setattr("esba.studies.distributed.DaskRunner", Killing)
        # the wait for the worker as long as a busy machine needs to start one (the test's own timeout bounds it)
        assert main([*grid, "--scheduler", address, "--connect-timeout", "600", "--chunk", "3", "--out", str(out)]) == EXIT_FAILED
        got, err = capfd.readouterr()
        assert got == "" and err.count("\n") == 1, err  # no Dask log lines, no traceback
        assert err.startswith(f"esba: error: the connection to the Dask scheduler at {address} was lost while chunk ")
        assert err.rstrip().endswith(f"the study stops; the rows solved so far are in {out}: rerun with --resume to go on")
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.kill()
                process.wait()
    kept = read_rows(out)
    assert len(kept) in (0, 3, 6)  # whole chunks, before the third
    monkeypatch.undo()
    assert main([*grid, "--resume", "--out", str(out)]) == EXIT_OK
    assert out.read_text() == here.read_text()


# ---------------------------------------------------------------------------------------------
# Ctrl-C


@needs_dask
@pytest.mark.timeout(300)  # the interrupt is not lost: without it the sleep below holds the test
def test_ctrl_c_while_a_local_cluster_starts_is_raised_and_the_cluster_stopped():
    """The interrupt lands while the cluster starts (or, on a fast machine, just after): it is not
    lost, it comes, and no worker process is left."""
    import multiprocessing

    before = set(multiprocessing.active_children())
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    with pytest.raises(KeyboardInterrupt):
        timer.start()
        with open_runner(workers=2):
            time.sleep(3600)  # the interrupt is raised here at the latest
    for process in set(multiprocessing.active_children()) - before:
        process.join(120)  # a worker told to stop takes its time to end on a busy machine
    assert set(multiprocessing.active_children()) <= before


@needs_dask
@pytest.mark.slow
@pytest.mark.ci
def test_cli_ctrl_c_while_the_cluster_starts_exits_130_promptly(tmp_path):
    """``esba sweep --workers 2`` interrupted as by the terminal's Ctrl-C (SIGINT to its process
    group, workers included) once its first worker process exists: the message, exit 130, no
    table, within seconds, and not a word from the workers."""
    argv = [sys.executable, "-m", "esba", "sweep", "--pressure", "0:0.2:100", "--payload", "0:2:40", "-n", "8", "--workers", "2", "--no-progress"]
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path, start_new_session=True)
    tasks = Path(f"/proc/{process.pid}/task")

    def children() -> list[str]:  # of every thread: Dask starts its workers from threads of its own
        found = []
        for task in list(tasks.glob("*")):
            try:
                found += (task / "children").read_text().split()
            except OSError:
                pass
        return found

    for _ in range(1500):
        if not tasks.exists() or children() or process.poll() is not None:
            break
        time.sleep(0.02)
    if not tasks.exists():
        time.sleep(1.0)  # no /proc: about when the cluster starts
    assert process.poll() is None, "the study ended before it could be interrupted"
    os.killpg(process.pid, signal.SIGINT)
    out, err = process.communicate(timeout=120)  # a process that does not stop fails the test here
    assert process.returncode == EXIT_INTERRUPTED and out == "" and err == "esba: interrupted\n", (process.returncode, out, err)


class _DM:
    """Stands for a CasADi DM whose conversion to NumPy is hit by Ctrl-C: CasADi's wrapper reports
    the KeyboardInterrupt as a SystemError."""

    def __array__(self, *args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("<function DM.__array__ at 0x7f0> returned a result with an exception set") from exc


@pytest.mark.parametrize("argv, message", [
    (["sweep", "--pressure", "0,0.1", "--no-compile", "--no-progress"], "esba: interrupted\n"),
    (["sweep", "--pressure", "0,0.1", "--no-compile", "--no-progress", "--resume", "--out", "{out}"],
     "esba: interrupted: the rows solved so far are in {out}; rerun with --resume to go on\n"),
    (["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20"], "esba: interrupted\n"),
    (["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20", "--mc-out", "{out}"],
     "esba: interrupted: the samples solved so far are in {out}; rerun with --resume to go on\n"),
])
def test_ctrl_c_inside_casadis_conversion_to_numpy_is_an_interrupt(capsys, monkeypatch, tmp_path, argv, message):
    out = str(tmp_path / "s.csv")

    def block(values, target):  # the mapped function's seven outputs, each hit by Ctrl-C when converted
        return [_DM()] * 7

    def interrupted(*args, **kwargs):
        return (block, block), "interpreted", 0.0, 0.0

    monkeypatch.setattr("esba.statics.batch.mapped_functions", interrupted)
    assert main([a.format(out=out) for a in argv]) == EXIT_INTERRUPTED
    assert capsys.readouterr().err == message.format(out=out)


# ---------------------------------------------------------------------------------------------
# the study file: one run at a time, damaged rows, a full disk


@pytest.mark.skipif(sys.platform == "win32", reason="study files are locked on POSIX systems")
def test_a_study_file_that_another_run_writes_is_refused_and_left_alone(capsys, tmp_path):
    import fcntl

    out = tmp_path / "s.csv"
    argv = ["sweep", "--pressure", "0:0.2:5", "--no-compile", "--no-progress", "--chunk", "2", "--resume", "--out", str(out)]
    assert main(argv[:-1] + [str(out)]) == EXIT_OK
    capsys.readouterr()
    lines = out.read_text().splitlines(keepends=True)
    out.write_text("".join(lines[:3]))  # an interrupted study: 2 rows of 5
    before = out.read_bytes()
    fd = os.open(out, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # another esba run is writing it
    try:
        pid = f" (pid {os.getpid()})" if os.path.exists("/proc/locks") else ""
        needle = f"{out} is being written by another esba run{pid}: wait for it to end, or give another file"
        _one_line_error(capsys, argv, needle)
        mc = ["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "20", "--mc-out", str(out)]
        _one_line_error(capsys, mc, needle)
        _one_line_error(capsys, [*mc, "--resume"], needle)
        _one_line_error(capsys, argv[:-5] + ["--out", str(out)], needle)  # a sweep in this process is a writer too
        with pytest.raises(StudyError, match="is being written by another esba run"):  # starting over does not truncate it either
            sweep_study(plan_sweep(Scene(), pressure=[0.0, 0.05, 0.1, 0.15, 0.2]), INTERPRETED, out=out)
        assert out.read_bytes() == before
    finally:
        os.close(fd)
    assert main(argv) == EXIT_OK and len(read_rows(out)) == 5
    assert "resumed at row 2" in capsys.readouterr().out


@pytest.mark.parametrize("damage", ['o"k', '"ok'])
def test_resume_refuses_a_row_with_a_stray_quote_and_leaves_the_file(capsys, tmp_path, damage):
    """A stray quote inside a cell, or at its start (the CSV reader would then read every row after
    it as one quoted cell, and resume would have cut them all off as a broken tail)."""
    out = tmp_path / "s.csv"
    argv = ["sweep", "--pressure", "0:0.2:10", "--no-compile", "--no-progress", "--chunk", "4", "--resume", "--out", str(out)]
    assert main(argv) == EXIT_OK
    capsys.readouterr()
    lines = out.read_text().splitlines(keepends=True)
    lines[3] = lines[3].replace(",ok,", f",{damage},", 1)  # row 3
    out.write_text("".join(lines))
    before = out.read_bytes()
    _one_line_error(capsys, argv, f"--resume {out}: row 3 cannot be read back exactly as CSV")
    assert out.read_bytes() == before


def test_study_file_keeps_quoted_cells_and_drops_a_row_cut_inside_one(tmp_path):
    path = tmp_path / "s.csv"
    f = StudyFile(path, "demo", {"grid": [1, 2, 3, 4]}, ["x", "message"], rows=4)
    f.start({"compile": "never"})
    f.append([{"x": 1, "message": 'a, "b"\nc'}, {"x": 2, "message": "plain"}])
    f.close()
    whole = path.read_bytes()
    path.write_bytes(whole + b'3,"cut, inside\nthe cell')  # the study stopped while writing a chunk
    g = StudyFile(path, "demo", {"grid": [1, 2, 3, 4]}, ["x", "message"], rows=4)
    rows: list = []
    assert g.resume(rows.append) == 2 and rows[0] == {"x": "1", "message": 'a, "b"\nc'}
    g.close()
    assert path.read_bytes() == whole


class _FillingDisk:
    """``os`` for esba.studies.chunks, on a disk that fills during the ``fail_at``-th write: the part that
    fits is written, then ENOSPC."""

    def __init__(self, fail_at: int) -> None:
        self.fail_at, self.calls = fail_at, 0

    def __getattr__(self, name):
        return getattr(os, name)

    def write(self, fd, data):
        self.calls += 1
        if self.calls == self.fail_at:
            os.write(fd, bytes(data[: len(data) // 2]))
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return os.write(fd, data)


def test_a_full_disk_stops_a_streamed_study_in_one_line_and_it_resumes(capsys, monkeypatch, tmp_path):
    grid = ["sweep", "--pressure", "0:0.2:10", "--no-compile", "--no-progress", "--chunk", "4"]
    here, out = tmp_path / "here.csv", tmp_path / "s.csv"
    assert main([*grid[:-2], "--out", str(here)]) == EXIT_OK  # in this process: one batch, no --chunk
    capsys.readouterr()
    monkeypatch.setattr("esba.studies.chunks.os", _FillingDisk(fail_at=3))  # the column names, chunk 0, then half of chunk 1
    assert main([*grid, "--resume", "--out", str(out)]) == EXIT_FAILED
    got, err = capsys.readouterr()
    assert got == "" and err == f"esba: error: {out}: cannot write (No space left on device); the rows solved so far are kept: rerun with --resume to go on\n"
    assert len(read_rows(out)) == 4 and out.read_bytes().endswith(b"\n")  # chunk 0 whole, nothing of chunk 1
    monkeypatch.undo()
    assert main([*grid, "--resume", "--out", str(out)]) == EXIT_OK
    assert out.read_text() == here.read_text()
    # the Monte Carlo's samples: the same line, with its own flag's words
    mc = ["solve", "--no-plot", "--sigma", "E=5%", "--monte-carlo", "30", "--mc-chunk", "10", "--mc-out", str(tmp_path / "mc.csv")]
    monkeypatch.setattr("esba.studies.chunks.os", _FillingDisk(fail_at=2))
    assert main(mc) == EXIT_FAILED
    assert capsys.readouterr().err == f"esba: error: {tmp_path / 'mc.csv'}: cannot write (No space left on device); the samples solved so far are kept: rerun with --resume to go on\n"


# ---------------------------------------------------------------------------------------------
# the benchmark


@needs_dask
@pytest.mark.slow
@pytest.mark.ci
def test_bench_scaling_writes_its_page(capsys, tmp_path):
    page = tmp_path / "scaling.md"
    assert main(["bench", "scaling", "--points", "400", "--segments", "2", "--repeat", "1", "--markdown", str(page), "--json"]) == EXIT_OK
    data = json.loads(capsys.readouterr().out)
    assert [r["workers"] for r in data["rows"]] == [0, 0, 1, 2] and all(r["identical"] for r in data["rows"])
    assert [c["chunk"] for c in data["chunks"]] == [128, 1000, 4000] and all(c["identical"] for c in data["chunks"])
    assert data["overhead"]["round_trip_s"] > 0 and len(data["clusters"]) == 2
    text = page.read_text()
    assert f"`esba bench scaling --points 400 --segments 2 --repeat 1 --markdown {page}`" in text
    # the sweep in this process at two sizes: how its time grows with the grid (linear: the same time per equilibrium)
    assert [g["points"] for g in data["growth"]] == [100, 400] and all(g["per_point_us"] > 0 for g in data["growth"])
    for heading in ("## Throughput against the worker count", "## In this process against the grid's size", "## What the chunk size does",
                    "## The overhead of one chunk", "dask-jobqueue"):
        assert heading in text
    assert "nan" not in text.lower() and "**no**" not in text
    # a second run of the benchmark finds the page up to date, times aside (rates, load averages, versions)
    from esba.pages.scaling import PAGE, ScalingSettings

    settings = ScalingSettings(points=400, segments=2, repeat=1, command=f"esba bench scaling --points 400 --segments 2 --repeat 1 --markdown {page}")
    check = PAGE.check(page, settings)
    assert check.ok, check.describe()
