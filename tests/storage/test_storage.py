"""One suite over every Store implementation: exact resume, crash safety, concurrent reading."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.storage import (
    HDF5Store,
    MemoryStore,
    RunState,
    Store,
    StoreMismatch,
    read_run,
    rng_from_state,
)

REPO = Path(__file__).resolve().parents[2]
PARAMS = ["kappa", "C"]
BLOBS = ["rmse_0cm", "rmse_1cm", "rmse_2cm"]
N_CHAINS = 4
CONFIG = {"case": "A", "priors": {"kappa": {"mean": 2.27, "sd": 0.1135}, "h": [10, 10, 10]}}
META = {"config_json": json.dumps(CONFIG), "data_hash": "abc123", "sampler": "toy-mh"}


class MemoryBackend:
    name = "memory"

    def create(self, tmp_path: Path, **kw) -> Store:
        return MemoryStore.create(PARAMS, BLOBS, N_CHAINS, META)

    def reopen(self, store: Store) -> Store:
        return MemoryStore.open_append(store)

    def read(self, store: Store):
        return MemoryStore.open_readonly(store).read()


class HDF5Backend:
    name = "hdf5"

    def create(self, tmp_path: Path, **kw) -> Store:
        return HDF5Store.create(tmp_path / "run.h5", PARAMS, BLOBS, N_CHAINS, META, **kw)

    def reopen(self, store: Store) -> Store:
        return HDF5Store.open_append(store.path)

    def read(self, store: Store):
        return read_run(store.path)


@pytest.fixture(params=[MemoryBackend(), HDF5Backend()], ids=lambda b: b.name)
def backend(request):
    return request.param


# ---------------------------------------------------------------------------------------------
# A small adaptive random-walk Metropolis sampler that uses every part of the resume state.


def log_prob(x: np.ndarray) -> np.ndarray:
    return -0.5 * np.sum((x / np.array([1.0, 2.0])) ** 2, axis=1)


def blobs_of(x: np.ndarray) -> np.ndarray:
    return np.abs(x[:, :1]) * np.array([1.0, 2.0, 3.0])


def initial_state(rng: np.random.Generator) -> RunState:
    x = rng.standard_normal((N_CHAINS, len(PARAMS)))
    return RunState.capture(
        x, log_prob(x), blobs_of(x), rng, extra={"iteration": 0}, arrays={"cov": 0.5 * np.eye(2)}
    )


def toy_run(store: Store, state: RunState, n_steps: int, block: int = 10) -> np.random.Generator:
    rng = state.make_rng()
    x, lp, bl = state.position, state.log_prob, state.blobs
    cov, it = state.arrays["cov"], state.extra["iteration"]
    for _ in range(n_steps):
        prop = x + rng.standard_normal(x.shape) @ np.linalg.cholesky(cov).T
        lp_prop = log_prob(prop)
        acc = np.log(rng.random(N_CHAINS)) < lp_prop - lp
        x = np.where(acc[:, None], prop, x)
        lp = np.where(acc, lp_prop, lp)
        bl = np.where(acc[:, None], blobs_of(prop), bl)
        it += 1
        cov = 0.95 * cov + 0.05 * (np.cov(x.T) + 1e-3 * np.eye(2))
        store.append(x, lp, bl, acc)
        if store.n_buffered == block:
            store.flush(RunState.capture(x, lp, bl, rng, {"iteration": it}, {"cov": cov}))
    store.flush(RunState.capture(x, lp, bl, rng, {"iteration": it}, {"cov": cov}))
    return rng


def test_25_plus_25_equals_50(backend, tmp_path: Path) -> None:
    straight_dir, resumed_dir = tmp_path / "a", tmp_path / "b"
    straight_dir.mkdir()
    resumed_dir.mkdir()
    init = initial_state(np.random.default_rng(42))

    a = backend.create(straight_dir)
    rng_a = toy_run(a, init, 50)
    a.close()

    b = backend.create(resumed_dir)
    toy_run(b, init, 25)
    b.close()
    b = backend.reopen(b)
    assert b.n_saved == 25
    state = b.state
    assert state.extra == {"iteration": 25}
    toy_run(b, state, 25)
    b.close()

    ra, rb = backend.read(a), backend.read(b)
    assert ra.n_saved == rb.n_saved == 50
    for name in ("chain", "log_prob", "blobs", "accepted"):
        np.testing.assert_array_equal(getattr(ra, name), getattr(rb, name), err_msg=name)
    assert ra.accepted.dtype == bool and 0.1 < ra.accepted.mean() < 0.95
    np.testing.assert_array_equal(ra.state.position, ra.chain[-1])
    np.testing.assert_array_equal(ra.state.arrays["cov"], rb.state.arrays["cov"])
    np.testing.assert_array_equal(ra.state.blobs, rb.state.blobs)
    # The restored Generators continue exactly where the straight run's Generator is.
    expected = rng_a.random(5)
    np.testing.assert_array_equal(rb.state.make_rng().random(5), expected)
    np.testing.assert_array_equal(ra.state.make_rng().random(5), expected)
    assert ra.param_names == PARAMS and ra.blob_names == BLOBS
    assert ra.meta["data_hash"] == "abc123" and ra.meta["sampler"] == "toy-mh"
    assert json.loads(ra.meta["config_json"]) == CONFIG
    assert ra.meta["version"] and ra.meta["created"]
    assert ra.get_chain(discard=10, thin=2, flat=True).shape == (20 * N_CHAINS, 2)


def test_partial_block_without_commit_leaves_last_good_block(backend, tmp_path, monkeypatch):
    store = backend.create(tmp_path)
    init = initial_state(np.random.default_rng(1))
    toy_run(store, init, 20)  # two committed blocks of 10
    good = backend.read(store)

    def crash(*args, **kwargs):
        raise KeyboardInterrupt("killed before the commit")

    x = good.state.position + 1.0
    for _ in range(5):
        store.append(x, log_prob(x), blobs_of(x), np.ones(N_CHAINS, bool))
    with monkeypatch.context() as m:
        m.setattr(store, "_commit", crash)
        with pytest.raises(KeyboardInterrupt):
            store.flush(RunState.capture(x, log_prob(x), blobs_of(x), np.random.default_rng(9)))
    with pytest.warns(RuntimeWarning, match="unflushed"):
        store.close()
    if isinstance(store, HDF5Store):  # the partial rows really reached the file: the tail
        import h5py  # slot the last commit does not name

        with h5py.File(store.path, "r") as f:
            slot = int(f["commit"][1])
            assert slot in (0, 1) and f["chain"].shape[0] == 0
            np.testing.assert_array_equal(f["tail/chain"][1 - slot, :25], np.r_[good.chain, [x] * 5])

    after = backend.read(store)
    assert after.n_saved == 20
    np.testing.assert_array_equal(after.chain, good.chain)
    np.testing.assert_array_equal(after.state.position, good.state.position)
    assert after.state.rng_state == good.state.rng_state
    # Resuming overwrites the uncommitted tail.
    store = backend.reopen(store)
    toy_run(store, store.state, 5)
    store.close()
    final = backend.read(store)
    assert final.n_saved == 25
    np.testing.assert_array_equal(final.chain[:20], good.chain)
    assert not np.any(final.chain[20:] == x)


def test_mismatch_names_changed_key(backend, tmp_path) -> None:
    store = backend.create(tmp_path)
    store.check_compatible(META)
    cfg = json.loads(json.dumps(CONFIG))
    cfg["priors"]["kappa"]["sd"] = 0.2
    cfg["priors"]["h"][1] = 12
    cfg["new_key"] = True
    with pytest.raises(StoreMismatch) as info:
        store.check_compatible({**META, "config_json": json.dumps(cfg)})
    msg = str(info.value)
    assert "priors.kappa.sd: 0.1135 -> 0.2" in msg
    assert "priors.h[1]: 10 -> 12" in msg and "new_key: added" in msg
    assert "case" not in msg
    with pytest.raises(StoreMismatch, match="data: the data file changed .*data hash abc123 -> zzz"):
        store.check_compatible({**META, "data_hash": "zzz"})
    with pytest.raises(StoreMismatch, match="param_names"):
        store.check_compatible({"param_names": ["kappa", "C", "h_0"]})
    assert issubclass(StoreMismatch, ValueError)
    store.close()


def test_input_checks(backend, tmp_path) -> None:
    store = backend.create(tmp_path)
    with pytest.raises(ValueError, match="positions has shape"):
        store.append(np.zeros((3, 2)), np.zeros(4), np.zeros((4, 3)), np.ones(4, bool))
    assert store.state is None and store.n_saved == 0 and store.read().chain.shape == (0, 4, 2)
    store.close()
    with pytest.raises(ValueError, match="closed"):
        store.append(np.zeros((4, 2)), np.zeros(4), np.zeros((4, 3)), np.ones(4, bool))


@pytest.mark.parametrize("bit_generator", ["PCG64", "MT19937", "SFC64", "Philox"])
def test_every_bit_generator_round_trips(backend, tmp_path, bit_generator) -> None:
    rng = np.random.Generator(getattr(np.random, bit_generator)(7))
    rng.random(3)
    store = backend.create(tmp_path)
    x = np.zeros((N_CHAINS, 2))
    store.save_arrays({"L": np.arange(6.0).reshape(2, 3)})
    store.flush(RunState.capture(x, log_prob(x), blobs_of(x), rng, extra={"k": [1, 2]}))
    store.close()
    state = backend.read(store).state
    restored = state.make_rng()
    assert type(restored.bit_generator).__name__ == bit_generator
    np.testing.assert_array_equal(restored.random(4), rng.random(4))
    np.testing.assert_array_equal(backend.reopen(store).load_arrays()["L"], np.arange(6.0).reshape(2, 3))
    assert state.extra == {"k": [1, 2]}


def test_rng_from_state_rejects_unknown() -> None:
    with pytest.raises(ValueError, match="bit generator"):
        rng_from_state({"bit_generator": "os"})


def test_hdf5_refuses_to_overwrite(tmp_path) -> None:
    store = HDF5Backend().create(tmp_path)
    store.close()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        HDF5Backend().create(tmp_path)
    HDF5Backend().create(tmp_path, overwrite=True).close()
    assert read_run(tmp_path / "run.h5").n_saved == 0


def test_hdf5_without_blobs(tmp_path) -> None:
    store = HDF5Store.create(tmp_path / "r.h5", ["a"], [], 2, {})
    store.append(np.ones((2, 1)), np.zeros(2), None, np.ones(2, bool))
    store.flush(RunState.capture(np.ones((2, 1)), np.zeros(2), None))
    store.close()
    run = read_run(tmp_path / "r.h5")
    assert run.blobs.shape == (1, 2, 0) and run.state.blobs.shape == (2, 0)


# ---------------------------------------------------------------------------------------------
# Another process writes; this one reads.

WRITER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from pavement_mcmc.storage import HDF5Store, RunState
    path, n_blocks, block, mode = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    m, p = 3, 2
    if mode == "create":
        store = HDF5Store.create(path, ["a", "b"], ["r"], m, {"sampler": "writer"})
    else:
        store = HDF5Store.open_append(path)
    start = store.n_saved
    open(path + ".ready", "w").close()
    rng = np.random.default_rng(0)
    for k in range(n_blocks):
        for _ in range(block):
            t = start
            x = t * 100.0 + np.arange(m)[:, None] * 10.0 + np.arange(p)
            store.append(x, np.full(m, -t), x[:, :1], np.ones(m, bool))
            start += 1
        store.flush(RunState.capture(x, np.full(m, -t), x[:, :1], rng, extra={"n": start}))
        time.sleep(0.004)
    store.close()
    """
)


def start_writer(tmp_path: Path, n_blocks: int, block: int, mode: str = "create"):
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    path = tmp_path / "live.h5"
    ready = Path(str(path) + ".ready")
    ready.unlink(missing_ok=True)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen(
        [sys.executable, str(script), str(path), str(n_blocks), str(block), mode], env=env
    )
    deadline = time.time() + 30
    while not ready.exists():
        assert proc.poll() is None, "writer died"
        assert time.time() < deadline, "writer did not start"
        time.sleep(0.01)
    return proc, path


def check_consistent(run) -> None:
    n = run.n_saved
    t = np.arange(n)[:, None, None]
    expected = t * 100.0 + np.arange(3)[None, :, None] * 10.0 + np.arange(2)
    np.testing.assert_array_equal(run.chain, expected)
    np.testing.assert_array_equal(run.log_prob, -np.broadcast_to(t[:, :, 0], (n, 3)))
    if n:
        np.testing.assert_array_equal(run.state.position, run.chain[-1])
        assert run.state.extra["n"] == n


def test_read_while_another_process_writes(tmp_path) -> None:
    proc, path = start_writer(tmp_path, n_blocks=150, block=5)
    seen = []
    with HDF5Store.open_readonly(path) as reader:  # one long-lived reader ...
        while proc.poll() is None:
            run = read_run(path)  # ... and fresh opens
            check_consistent(run)
            live = reader.read()
            check_consistent(live)
            seen.append(run.n_saved)
    assert proc.wait() == 0
    assert seen == sorted(seen)
    assert len(set(seen)) >= 3, seen  # really read at several points during the run
    final = read_run(path)
    assert final.n_saved == 750
    check_consistent(final)


def test_kill_9_then_read_and_resume(tmp_path) -> None:
    proc, path = start_writer(tmp_path, n_blocks=100_000, block=7)
    deadline = time.time() + 30
    while read_run(path).n_saved < 100:
        assert time.time() < deadline
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    run = read_run(path)
    assert run.n_saved >= 100 and run.n_saved % 7 == 0
    check_consistent(run)
    proc, path = start_writer(tmp_path, n_blocks=3, block=7, mode="append")  # recovers
    assert proc.wait() == 0
    assert Path(str(path) + ".crashed").exists()
    final = read_run(path)
    assert final.n_saved == run.n_saved + 21
    check_consistent(final)
    assert final.meta["created"] == run.meta["created"]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_a_zombie_writer_is_not_alive() -> None:
    """A writer that has exited but is not yet reaped (a zombie) holds no file: its store is not
    busy. kill(pid, 0) alone still finds it (a killed batch's orphaned Dask worker stays a zombie
    for about a second here, and test_batch's rerun once found its unit's store busy)."""
    from pavement_mcmc.storage.hdf5 import _pid_alive

    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        t0 = time.time()
        while open(f"/proc/{dead.pid}/stat").read().rsplit(")", 1)[1].split()[0] != "Z":
            assert time.time() - t0 < 20, "the child did not exit"
            time.sleep(0.01)
        os.kill(dead.pid, 0)  # still there for kill(pid, 0)
        assert not _pid_alive(dead.pid)
        assert _pid_alive(live.pid) and _pid_alive(os.getpid())
    finally:
        live.kill()
        live.wait()
        dead.wait()


#: argv[2] == "write": write 3 blocks of 7 rows, then die by SIGKILL (the file is left open);
#: "recover": reopen it, dying by SIGKILL when the recovery renames its fresh copy into place
KILLED = textwrap.dedent(
    """
    import os, signal, sys
    import numpy as np
    from pavement_mcmc.storage import HDF5Store, RunState
    path, what = sys.argv[1], sys.argv[2]
    if what == "write":
        store = HDF5Store.create(path, ["a", "b"], ["r"], 3, {})
        for t in range(21):
            x = t * 100.0 + np.arange(3)[:, None] * 10.0 + np.arange(2)
            store.append(x, np.full(3, -t), x[:, :1], np.ones(3, bool))
            if t % 7 == 6:
                store.flush(RunState.capture(x, np.full(3, -t), x[:, :1], extra={"n": t + 1}))
    else:
        replace = os.replace
        def dying(src, dst):
            if str(src).endswith(".recovering"):
                os.kill(os.getpid(), signal.SIGKILL)
            replace(src, dst)
        os.replace = dying
        HDF5Store.open_append(path)
    os.kill(os.getpid(), signal.SIGKILL)
    """
)


def test_a_recovery_killed_before_its_last_rename_leaves_the_run_at_its_path(tmp_path) -> None:
    """The recovery of a killed writer's file renamed the file away, then its fresh copy in:
    killed between the two renames, no run was left at the path (a resume started afresh)."""
    (tmp_path / "killed.py").write_text(KILLED)
    path = tmp_path / "live.h5"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    for what in ("write", "recover"):
        p = subprocess.run([sys.executable, str(tmp_path / "killed.py"), str(path), what], env=env,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == -signal.SIGKILL, (what, p.returncode, p.stderr[-2000:])
    assert Path(str(path) + ".recovering").exists()  # killed with the copy made, not renamed
    run = read_run(path)
    assert run.n_saved == 21
    check_consistent(run)
    proc, path = start_writer(tmp_path, n_blocks=2, block=7, mode="append")
    assert proc.wait() == 0
    final = read_run(path)
    assert final.n_saved == 35
    check_consistent(final)


def test_a_resume_while_a_reader_holds_the_file_says_busy_not_damaged(tmp_path) -> None:
    """A SWMR reader in another process holds a shared lock on the file; a resume's open for
    writing then fails to lock it ("unable to lock file", errno 11), which was reported as a
    damaged run. It is busy: StoreBusy, and the file is left exactly as it was."""
    from pavement_mcmc.storage import StoreBusy

    store = HDF5Store.create(tmp_path / "run.h5", PARAMS, BLOBS, N_CHAINS, META)
    toy_run(store, initial_state(np.random.default_rng(5)), 20)
    store.close()
    path = store.path
    before = Path(path).read_bytes()
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    hold = "import sys, time\nfrom pavement_mcmc.storage import HDF5Store\n" \
           "s = HDF5Store.open_readonly(sys.argv[1])\nprint('open', flush=True)\ntime.sleep(60)\n"
    reader = subprocess.Popen([sys.executable, "-c", hold, path], env=env, stdout=subprocess.PIPE,
                              text=True)
    try:
        assert reader.stdout.readline().strip() == "open"
        with pytest.raises(StoreBusy, match="open in another process.*reader") as info:
            HDF5Store.open_append(path)
        assert "damaged" not in str(info.value)
    finally:
        reader.kill()
        reader.wait()
    assert Path(path).read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5"]  # no .crashed, no copy
    HDF5Store.open_append(path).close()  # the reader gone, it resumes
    assert read_run(path).n_saved == 20
