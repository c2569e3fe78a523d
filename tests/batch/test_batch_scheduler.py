"""A batch on an existing Dask cluster started by hand (``dask scheduler``, ``dask worker``), and
that cluster's scheduler killed mid-batch (issues 24 and 25): the table is byte-identical to the
embedded cluster's, a lost scheduler stops the batch with one clear error and no table, and
running the batch again finishes it without redoing finished units."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pavement_mcmc.batch import COSTS, TABLE, read_table, run_batch

REPO = Path(__file__).resolve().parents[2]
DASK = Path(sys.executable).with_name("dask")
pytestmark = pytest.mark.skipif(not DASK.exists() and not shutil.which("dask"),
                                reason="the dask command line (dask scheduler / dask worker) is missing")
ENV = {**os.environ, "PYTHONPATH": str(REPO), "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
#: the batch of test_batch.py (three 6 h windows of Case A, seed 5), run in a subprocess
BATCH = ("import sys; sys.path.insert(0, {tests!r}); from test_batch import _units; "
         "from pavement_mcmc.batch import run_batch; "
         "run_batch(_units(), {out!r}, seed=5, scheduler={address!r}, counter={counter!r})")


class Cluster:
    """``dask scheduler`` and ``dask worker --nworkers 2 --nthreads 1`` on 127.0.0.1."""

    def __init__(self, logs: Path) -> None:
        self._pick_port()
        self.logs = logs
        self.scheduler = self.workers = None

    def _pick_port(self) -> None:
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        self.port = s.getsockname()[1]
        s.close()
        self.address = f"tcp://127.0.0.1:{self.port}"

    def _listening(self, timeout: float = 60.0) -> bool:
        """Wait until the scheduler accepts connections; False if it exited first."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.scheduler.poll() is not None:
                return False
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1.0).close()
                return True
            except OSError:
                time.sleep(0.2)
        return False

    def _start(self, *args: str) -> subprocess.Popen:
        log = open(self.logs / f"{args[0]}.log", "a")  # noqa: SIM115 - the process keeps it
        return subprocess.Popen([str(DASK), *args], env=ENV, stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True)

    def start_scheduler(self, new_port: bool = True) -> None:
        """Start it and wait until it listens. The port was free when picked, but another
        process (the embedded cluster of ``reference``) may take it before the scheduler binds
        it ("Address already in use" made this test flaky): then another port, when allowed."""
        for _ in range(5):
            self.scheduler = self._start("scheduler", "--host", "127.0.0.1", "--port",
                                         str(self.port), "--no-dashboard")
            if self._listening():
                return
            if self.scheduler.poll() is None:
                os.killpg(self.scheduler.pid, signal.SIGKILL)
            self.scheduler.wait()
            if not new_port:
                break
            self._pick_port()
        raise RuntimeError(f"dask scheduler did not start; see {self.logs / 'scheduler.log'}")

    def start_workers(self) -> None:
        self.workers = self._start("worker", self.address, "--nworkers", "2", "--nthreads", "1",
                                   "--no-dashboard")

    def kill_scheduler(self) -> None:
        """Kill the scheduler. Its workers stop by themselves when they lose it (Dask:
        "worker-handle-scheduler-connection-broken"), a unit in flight with them."""
        os.killpg(self.scheduler.pid, signal.SIGKILL)
        self.scheduler.wait()
        try:
            self.workers.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(self.workers.pid, signal.SIGKILL)
            self.workers.wait()

    def restart(self) -> None:
        """What the cluster's operator does: a scheduler and workers at the same address."""
        self.start_scheduler(new_port=False)
        self.start_workers()

    def stop(self) -> None:
        for p in (self.workers, self.scheduler):
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    c = Cluster(tmp_path_factory.mktemp("dask_logs"))
    c.start_scheduler()
    c.start_workers()
    yield c
    c.stop()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The undisturbed batch on the embedded cluster."""
    from test_batch import _units

    out = tmp_path_factory.mktemp("embedded")
    run_batch(_units(), out, seed=5, n_workers=2)
    return out


def _unit_starts(counter: Path) -> dict[str, int]:
    out: dict[str, int] = {}
    for line in counter.read_text().splitlines() if counter.exists() else []:
        out[line.split()[0]] = out.get(line.split()[0], 0) + 1
    return out


def test_a_batch_on_a_cluster_started_by_hand_matches_the_embedded_one(cluster, reference, tmp_path):
    out = tmp_path / "b"
    p = subprocess.run([sys.executable, "-m", "pavement_mcmc", "batch", "runs/caseA.toml",
                        "--windows", "0-6", "6-12", "12-18", "--out", str(out), "--no-progress",
                        "--no-figure", "--seed", "5", "--scheduler", cluster.address,
                        "--set", "model.h.kind=uniform", "model.h.n=2", "sampler.ess_target=100",
                        "sampler.max_steps=2000", "sampler.n_walkers=8"],
                       env=ENV, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:] + p.stdout[-2000:]
    assert (out / TABLE).read_bytes() == (reference / TABLE).read_bytes()
    costs = read_table(out / COSTS)  # each worker's own peak while the unit ran
    assert [r["key"] for r in costs] == [r["key"] for r in read_table(out / TABLE)]
    assert all(50 < r["peak_rss_mb"] < 2000 and r["elapsed_s"] > 0 for r in costs), costs
    assert "peak memory" in p.stdout


def _kill_scheduler_mid_batch(cluster: Cluster, out: Path, counter: Path, after: str,
                              six: bool = False) -> str:
    """Run the batch; kill the scheduler once one more unit has ended (``after="end"``) or has
    started sampling (``"start"``: mid-unit); restart the scheduler at the same address."""
    def progress() -> int:
        if after == "end":
            return len(list(out.glob("*/unit.json")))
        return sum(_unit_starts(counter).values())

    before = progress()
    code = BATCH.format(tests=str(Path(__file__).parent), out=str(out), address=cluster.address,
                        counter=str(counter))
    if six:
        code = code.replace("from test_batch import _units", "from test_batch_scheduler import "
                            "_six_units as _units")
    proc = subprocess.Popen([sys.executable, "-c", code], env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while progress() < before + 1:
        assert time.time() - t0 < 300 and proc.poll() is None, proc.communicate()[1][-3000:]
        time.sleep(0.05)
    time.sleep(0.3 if after == "start" else 0.0)
    cluster.kill_scheduler()
    _, err = proc.communicate(timeout=300)
    assert proc.returncode != 0 and not (out / TABLE).exists(), err[-3000:]
    cluster.restart()
    return err


def _six_units():
    from test_batch import SMALL

    from pavement_mcmc.batch import window_units

    wins = [(0, 6), (6, 12), (12, 18), (18, 24), (3, 9), (15, 21)]
    return window_units(REPO / "runs" / "caseA.toml", windows=wins, overrides=SMALL)


@pytest.mark.parametrize("kills", [1, pytest.param(3, marks=pytest.mark.slow)])
def test_a_scheduler_killed_mid_batch_then_the_batch_run_again(cluster, reference, tmp_path, kills):
    out, counter = tmp_path / "b", tmp_path / "starts.txt"
    units, ref = __import__("test_batch")._units(), reference
    if kills > 1:  # six units, so that three kills each find work in flight
        units, ref = _six_units(), tmp_path / "ref6"
        run_batch(units, ref, seed=5, n_workers=2)
    for _ in range(kills):
        err = _kill_scheduler_mid_batch(cluster, out, counter, "end" if kills == 1 else "start",
                                        six=kills > 1)
        assert "SchedulerLost: the Dask scheduler" in err and "went away" in err, err[-3000:]
    finished = {p.parent.name: p.stat().st_mtime_ns for p in out.glob("*/unit.json")}
    run_batch(units, out, seed=5, scheduler=cluster.address, counter=counter)
    assert (out / TABLE).read_bytes() == (ref / TABLE).read_bytes()
    for key, mtime in finished.items():  # finished units are read back, not redone
        assert (out / key / "unit.json").stat().st_mtime_ns == mtime
    assert all(n <= kills + 1 for n in _unit_starts(counter).values())
