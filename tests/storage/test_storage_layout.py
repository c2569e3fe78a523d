"""Where an HDF5 run's rows lie (format 3): a committed row is never rewritten.

Whole chunks of rows are written once; the rows after the last whole chunk go, at each flush,
into the one of two tail slots the last commit does not use. What must hold: a flush torn
mid-write (a writer killed by SIGKILL: Linux may cut a page-cache write between pages) leaves
every committed row readable; no byte of a committed row's chunk changes in later flushes; rows
read back exactly across chunk boundaries, flushes of any size and resumes; a run of format 2
is still read and resumed."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_storage import BLOBS, META, N_CHAINS, PARAMS, initial_state, toy_run

from pavement_mcmc.storage import FORMAT_VERSION, HDF5Store, RunState, read_run

REPO = Path(__file__).resolve().parents[2]
ROWS = ("chain", "log_prob", "blobs", "accepted")
PAGE = 4096


def _same_rows(a, b) -> bool:
    return a.n_saved == b.n_saved and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ROWS)


def _raw_chunks(path: Path) -> list[tuple[str, int, int]]:
    """(dataset, byte offset, size) of every stored chunk of every chunked dataset."""
    out = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.chunks:
            for i in range(obj.id.get_num_chunks()):
                info = obj.id.get_chunk_info(i)
                out.append((name, int(info.byte_offset), int(info.size)))

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return out


def test_a_flush_torn_by_a_kill_loses_no_committed_row(tmp_path, monkeypatch) -> None:
    """A flush is made and never committed; every chunk it wrote is then torn as a SIGKILL
    tears a write (its first page new, the rest as before). Format 2 rewrote the chunk holding
    the committed rows: torn, they failed their checksum and the run was refused."""
    path = tmp_path / "run.h5"
    store = HDF5Store.create(path, PARAMS, BLOBS, N_CHAINS, META)
    toy_run(store, initial_state(np.random.default_rng(3)), 25)  # commits at 10, 20, 25 steps
    good = read_run(path)
    before = path.read_bytes()
    x = good.state.position + 1.0
    for _ in range(5):
        store.append(x, -np.ones(N_CHAINS), np.zeros((N_CHAINS, 3)), np.ones(N_CHAINS, bool))

    def killed(*args, **kwargs):
        raise KeyboardInterrupt("killed before the commit")

    monkeypatch.setattr(store, "_commit", killed)
    with pytest.raises(KeyboardInterrupt):
        store.flush(RunState.capture(x, -np.ones(N_CHAINS), np.zeros((N_CHAINS, 3))))
    with pytest.warns(RuntimeWarning, match="unflushed"):
        store.close()
    after = bytearray(path.read_bytes())
    old = before.ljust(len(after), b"\0")
    torn = []
    for name, off, size in _raw_chunks(path):
        if after[off : off + size] != old[off : off + size]:
            cut = min(off + size - 1, (off // PAGE + 1) * PAGE)  # the first page is new
            after[cut : off + size] = old[cut : off + size]
            torn.append(name)
    assert {"chain", "tail/chain"} & set(torn), torn  # the flush really wrote rows
    path.write_bytes(bytes(after))
    run = read_run(path)  # format 2: StoreDamaged, "its 25 committed steps cannot be read"
    assert _same_rows(run, good) and run.n_saved == 25
    assert run.state.rng_state == good.state.rng_state


#: 32 chains of 128 parameters: 8 rows per chunk (chunks of 2^18 bytes)
WIDE = ([f"p{i}" for i in range(128)], ["b"], 32)


def _wide_rows(rng: np.random.Generator, n: int) -> list[tuple]:
    m, p = WIDE[2], len(WIDE[0])
    out = []
    for _ in range(n):
        x = rng.standard_normal((m, p))
        out.append((x, x[:, 0] * 2.0, x[:, 1:2], x[:, 2] > 0))
    return out


def _flush(store, rows: list[tuple], n_steps: int) -> None:
    for r in rows:
        store.append(*r)
    x = rows[-1][0] if rows else np.zeros((WIDE[2], len(WIDE[0])))
    store.flush(RunState.capture(x, x[:, 0], x[:, 1:2], extra={"n": n_steps}))


def test_no_byte_of_a_committed_rows_chunk_changes_in_later_flushes(tmp_path) -> None:
    """After each one-step flush, the bytes of every row dataset's chunk that holds committed
    rows are recorded; no later flush may change them (format 2 rewrote the chunk of the last
    rows at every flush until it was full)."""
    path = tmp_path / "run.h5"
    store = HDF5Store.create(path, *WIDE, {})
    rng = np.random.default_rng(1)
    seen: dict[tuple[str, int], bytes] = {}
    for step in range(1, 31):
        _flush(store, _wide_rows(rng, 1), step)
        data = path.read_bytes()
        for (name, off), old in seen.items():
            assert data[off : off + len(old)] == old, (name, off, step)
        for name in ("chain", "log_prob", "accepted"):
            ds = store._ds(name)
            for i in range(ds.id.get_num_chunks()):
                info = ds.id.get_chunk_info(i)
                if info.chunk_offset[0] < step:  # holds committed rows
                    off, size = int(info.byte_offset), int(info.size)
                    seen.setdefault((name, off), data[off : off + size])
    store.close()
    assert len(seen) >= 3 * 3  # 3 whole chunks of 3 datasets at least
    assert read_run(path).n_saved == 30


@pytest.mark.parametrize("blocks", [[1, 7, 0, 8, 3, 22, 0, 1, 1, 1, 17, 8],
                                    [40], [0, 0, 5], [8, 8, 8], [9, 15, 1, 7]])
def test_rows_read_back_exactly_across_chunks_and_resumes(tmp_path, blocks) -> None:
    """8 rows a chunk: flushes ending exactly on a chunk boundary, bigger than a chunk (several
    whole chunks and a tail), of one step, of none (the state alone), and a resume midway."""
    path = tmp_path / "run.h5"
    rng = np.random.default_rng(len(blocks))
    store = HDF5Store.create(path, *WIDE, {})
    assert read_run(path).n_saved == 0 and read_run(path).state is None  # slot -1
    assert read_run(path).chain.shape == (0, 32, 128)
    written: list[tuple] = []
    for k, n in enumerate(blocks):
        rows = _wide_rows(rng, n)
        written += rows
        _flush(store, rows, len(written))
        if k == len(blocks) // 2:  # resume midway
            store.close()
            store = HDF5Store.open_append(path)
        run = read_run(path)
        assert run.n_saved == len(written) and run.state.extra == {"n": len(written)}
        for j, name in enumerate(ROWS):
            want = np.array([r[j] for r in written]).reshape(getattr(run, name).shape)
            np.testing.assert_array_equal(getattr(run, name), want, err_msg=f"{name} after {k}")
    store.close()
    assert read_run(path).meta["format_version"] == FORMAT_VERSION == 3


def _as_format_2(path: Path) -> None:
    """Rewrite a closed run in the layout of format 2: every row in the row datasets, no tail."""
    run = read_run(path)
    with h5py.File(path, "r+") as f:
        for name in ROWS:
            f[name].resize(run.n_saved, axis=0)
            if getattr(run, name).size:
                f[name][:] = getattr(run, name)
        del f["tail"]
        meta = json.loads(f.attrs["meta_json"])
        meta["format_version"] = 2
        f.attrs["meta_json"] = json.dumps(meta, sort_keys=True)
        f.attrs["format_version"] = 2


def _straight_and_format_2(tmp_path: Path, seed: int, n: int, first: int) -> Path:
    """``a.h5``: a toy run of ``n`` steps; returns ``b.h5``: its ``first`` steps, in format 2."""
    init = initial_state(np.random.default_rng(seed))
    for name, steps in (("a.h5", n), ("b.h5", first)):
        store = HDF5Store.create(tmp_path / name, PARAMS, BLOBS, N_CHAINS, META)
        toy_run(store, init, steps)
        store.close()
    _as_format_2(tmp_path / "b.h5")
    return tmp_path / "b.h5"


def test_a_run_of_format_2_is_read_and_resumed_in_format_2(tmp_path) -> None:
    path = _straight_and_format_2(tmp_path, 42, 50, 25)
    half = read_run(tmp_path / "a.h5")
    old = read_run(path)
    assert old.meta["format_version"] == 2 and old.n_saved == 25
    assert all(np.array_equal(getattr(old, k), getattr(half, k)[:25]) for k in ROWS)
    store = HDF5Store.open_append(path)
    toy_run(store, store.state, 25)
    store.close()
    a, b = read_run(tmp_path / "a.h5"), read_run(path)
    assert b.meta["format_version"] == 2 and _same_rows(a, b) and b.n_saved == 50
    assert a.state.rng_state == b.state.rng_state
    with h5py.File(path, "r") as f:
        assert "tail" not in f and f["chain"].shape[0] == 50


#: write rows t*100 + chain*10 + parameter, in flushes of 1 to 3 steps, 8 rows a chunk, until
#: killed; print each committed count
KILLED = textwrap.dedent(
    """
    import sys
    import numpy as np
    from pavement_mcmc.storage import HDF5Store, RunState
    path = sys.argv[1]
    m, p = 32, 128
    store = HDF5Store.create(path, [f"p{i}" for i in range(p)], [], m, {})
    rng = np.random.default_rng(int(sys.argv[2]))
    t = 0
    while True:
        for _ in range(int(rng.integers(1, 4))):
            x = t * 100.0 + np.arange(m)[:, None] * 10.0 + np.arange(p)
            store.append(x, np.full(m, -t), None, np.ones(m, bool))
            t += 1
        store.flush(RunState.capture(x, np.full(m, -t + 1.0), None, extra={"n": t}))
        print(t, flush=True)
    """
)


def test_writers_killed_during_flushes_leave_every_committed_step(tmp_path) -> None:
    """Real SIGKILLs at random moments of writers flushing chunks of 256 kB, 1 to 3 steps a
    flush: every file reads with at least the steps last reported committed, all exact."""
    script = tmp_path / "killed.py"
    script.write_text(KILLED)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    rng = np.random.default_rng(11)
    for trial in range(6):
        path = tmp_path / f"run{trial}.h5"
        proc = subprocess.Popen([sys.executable, str(script), str(path), str(trial)], env=env,
                                stdout=subprocess.PIPE, text=True)
        first = proc.stdout.readline()  # the first commit is made
        assert first.strip() == "" or int(first) > 0
        time.sleep(float(rng.uniform(0.05, 0.6)))
        proc.send_signal(signal.SIGKILL)
        rest = proc.stdout.read().split()
        proc.wait()
        reported = int(rest[-1]) if rest else int(first)
        run = read_run(path)
        assert run.n_saved >= reported, (trial, run.n_saved, reported)
        t = np.arange(run.n_saved)[:, None, None]
        np.testing.assert_array_equal(
            run.chain, t * 100.0 + np.arange(32)[None, :, None] * 10.0 + np.arange(128))
        assert run.state.extra["n"] == run.n_saved


def test_a_killed_writer_of_a_format_2_run_is_recovered_into_format_3(tmp_path) -> None:
    """A writer continuing a run of format 2 is killed: the resume copies the committed steps
    into a fresh file, of format 3, and continues it as the straight run."""
    path = _straight_and_format_2(tmp_path, 8, 40, 20)
    killed = ("import os, signal, sys\nfrom pavement_mcmc.storage import HDF5Store\n"
              "from test_storage import toy_run\ns = HDF5Store.open_append(sys.argv[1])\n"
              "toy_run(s, s.state, 10)\nos.kill(os.getpid(), signal.SIGKILL)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(Path(__file__).parent)])}
    p = subprocess.run([sys.executable, "-c", killed, str(path)], env=env, timeout=120,
                       capture_output=True, text=True)
    assert p.returncode == -signal.SIGKILL, p.stderr[-2000:]
    assert read_run(path).meta["format_version"] == 2 and read_run(path).n_saved == 30
    store = HDF5Store.open_append(path)  # recovers: the writer was killed
    toy_run(store, store.state, 10)
    store.close()
    a, b = read_run(tmp_path / "a.h5"), read_run(path)
    assert b.meta["format_version"] == 3 and _same_rows(a, b) and b.n_saved == 40
    assert a.state.rng_state == b.state.rng_state
    assert Path(str(path) + ".crashed").exists()
