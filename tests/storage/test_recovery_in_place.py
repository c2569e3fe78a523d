"""A dead writer's run continued where it lies (:mod:`pavement_mcmc.storage.recovery`).

Before, ``resume`` after a full disk always copied the committed steps into a fresh file beside
the old one: on a disk that could not hold both it failed again ("No space left on device" while
writing ``chain.h5.recovering``), however much of the run's own growth had been freed. What must
hold now: on a genuine full disk (a small ``tmpfs``, as root) given less room than a copy
needs, ``resume`` ends at the undisturbed run's steps with its rows, Generator and summaries; a
kill -9 at each moment of the in-place way leaves a run that resumes to the same end; a flipped
byte in a committed row is refused with the file left as it was; a copy that cannot fit is
refused in one line that says how much to free.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from pavement_mcmc.storage import HDF5Store, StoreDamaged, StoreWriteFailed, read_run, recovery

REPO = Path(__file__).resolve().parents[2]
ROWS = ("chain", "log_prob", "blobs", "accepted")

#: a toy writer (rows drawn from the stored Generator, so a resume continues it): argv path,
#: rows, the file-size limit (0: none), and the moment of the in-place way to die by SIGKILL
#: ("never"); it always takes the in-place way (COPY_ROOM out of reach)
WRITER = textwrap.dedent(
    """
    import os, resource, signal, sys
    from pavement_mcmc.storage import HDF5Store, recovery
    path, total, limit, kill_at = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    if limit:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    recovery.COPY_ROOM = 10**9

    def die(*_):
        os.kill(os.getpid(), signal.SIGKILL)

    def after(owner, name, wrap=staticmethod):
        real = getattr(owner, name)
        setattr(owner, name, wrap(lambda *a, **k: (real(*a, **k), die())[0]))

    if kill_at == "extended":  # the file made as long as HDF5 recorded (a hole)
        after(os, "truncate", lambda f: f)
    elif kill_at == "opened":  # opened read-write, its flags cleared, not yet checked
        after(recovery, "open_swmr_writer", lambda f: f)
    elif kill_at == "checked":  # read back and checked, the writer not yet recorded
        HDF5Store._start_writing = classmethod(die)
    elif kill_at == "rows":  # the first block's rows written and flushed, not committed
        real_rows = HDF5Store._write_rows
        def rows(self, *a):
            real_rows(self, *a)
            self._f.flush()
            die()
        HDF5Store._write_rows = rows
    elif kill_at == "committed":  # right after the first commit in place
        after(HDF5Store, "_commit", lambda f: f)
    sys.path.insert(0, {tests!r})
    from toy_writer import write
    write(path, total)
    """
).replace("{tests!r}", repr(str(Path(__file__).resolve().parent)))


def _write(tmp: Path, path: Path, total: int = 1400, limit: int = 0, kill_at: str = "never"):
    (tmp / "writer.py").write_text(WRITER)
    return subprocess.run([sys.executable, str(tmp / "writer.py"), str(path), str(total),
                           str(limit), kill_at], env={**os.environ, "PYTHONPATH": str(REPO)},
                          capture_output=True, text=True, timeout=300)


def _same(a, b) -> bool:
    return (a.n_saved == b.n_saved and a.state.rng_state == b.state.rng_state
            and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ROWS))


@pytest.fixture(scope="module")
def toy(tmp_path_factory) -> tuple[Path, Path]:
    """An undisturbed toy run of 1400 rows (2.2 MB), and the same run stopped by a file-size
    limit of 1.2 MB: a dead writer's file (679 rows: a whole chunk and a tail), marked open and
    shorter than HDF5 recorded."""
    tmp = tmp_path_factory.mktemp("toy")
    assert _write(tmp, tmp / "straight.h5").returncode == 0
    p = _write(tmp, tmp / "stopped.h5", limit=1_200_000)
    assert p.returncode == 3, p.stderr[-2000:]
    with open(tmp / "stopped.h5", "rb") as fh:
        assert fh.read(12)[11] != 0  # the status flags of a writer that did not close it
    return tmp / "straight.h5", tmp / "stopped.h5"


@pytest.mark.parametrize("kill_at", ["extended", "opened", "checked", "rows", "committed"])
def test_a_kill_at_any_moment_of_the_in_place_way_resumes_to_the_same_run(toy, tmp_path, kill_at):
    straight, stopped = toy
    path = tmp_path / "run.h5"
    shutil.copy(stopped, path)
    kept = read_run(path)
    p = _write(tmp_path, path, kill_at=kill_at)
    assert p.returncode == -signal.SIGKILL, (p.returncode, p.stderr[-2000:])
    after = read_run(path)  # still a run, its committed rows the stopped run's or more
    assert after.n_saved >= kept.n_saved and all(
        np.array_equal(getattr(after, k)[: kept.n_saved], getattr(kept, k)) for k in ROWS)
    p = _write(tmp_path, path)
    assert p.returncode == 0, p.stderr[-2000:]
    assert _same(read_run(path), read_run(straight))
    assert sorted(q.name for q in tmp_path.iterdir()) == ["run.h5", "writer.py"]  # no copy


def test_a_resume_killed_before_it_writes_leaves_a_run_readers_open(toy, tmp_path):
    """A whole run reopened, its writer killed before its first write: before, the file was
    opened read-write without SWMR and switched to SWMR after the writer record, so a kill in
    between left it marked as written without SWMR, refused by every reader and by resume."""
    straight, _ = toy
    path = tmp_path / "run.h5"
    shutil.copy(straight, path)
    p = _write(tmp_path, path, kill_at="checked")
    assert p.returncode == -signal.SIGKILL, (p.returncode, p.stderr[-2000:])
    assert _same(read_run(path), read_run(straight))
    assert _write(tmp_path, path, total=1407).returncode == 0
    assert read_run(path).n_saved == 1407


def test_in_place_continues_a_cut_file_to_the_undisturbed_run(toy, tmp_path):
    straight, stopped = toy
    path = tmp_path / "run.h5"
    shutil.copy(stopped, path)
    p = _write(tmp_path, path)
    assert p.returncode == 0, p.stderr[-2000:]
    assert _same(read_run(path), read_run(straight))
    assert not Path(str(path) + ".crashed").exists()


def _committed_chunk(path: Path, where: str) -> int:
    """The file offset of committed rows: the first whole chunk of ``chain`` or the tail slot
    the commit names."""
    with h5py.File(path, "r", swmr=True, libver="latest") as f:
        n_saved, slot = (int(v) for v in f["commit"][:2])
        assert n_saved > 341 and n_saved % 341  # a whole chunk (341 rows) and a tail
        if where == "chunk":
            return int(f["chain"].id.get_chunk_info(0).byte_offset)
        return int(f["tail/chain"].id.get_chunk_info_by_coord((slot, 0, 0, 0)).byte_offset)


@pytest.mark.parametrize("where", ["chunk", "tail"])
def test_a_flipped_byte_in_a_committed_row_is_refused_in_place_and_left_alone(toy, tmp_path,
                                                                                monkeypatch, where):
    _, stopped = toy
    path = tmp_path / "run.h5"
    shutil.copy(stopped, path)
    off = _committed_chunk(path, where) + 5000
    with open(path, "r+b") as fh:
        fh.seek(off)
        b = fh.read(1)
        fh.seek(off)
        fh.write(bytes([b[0] ^ 4]))
    before = path.read_bytes()
    monkeypatch.setattr(recovery, "COPY_ROOM", 10**9)
    with pytest.raises(StoreDamaged, match="chain.*do not match their checksum|fletcher32"):
        HDF5Store.open_append(path)
    assert path.read_bytes() == before
    assert sorted(q.name for q in tmp_path.iterdir()) == ["run.h5"]


def test_a_copy_without_room_is_refused_in_one_line_with_the_bytes_to_free(toy, tmp_path,
                                                                             monkeypatch):
    _, stopped = toy
    path = tmp_path / "run.h5"
    shutil.copy(stopped, path)
    before = path.read_bytes()
    monkeypatch.setattr(recovery, "_hdf5_library", lambda: None)  # in place impossible
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(recovery.shutil, "disk_usage",
                        lambda _: usage._replace(free=100_000))
    with pytest.raises(StoreWriteFailed) as info:
        HDF5Store.open_append(path)
    msg = str(info.value)
    need = recovery.copy_bytes(read_run(path))
    assert "\n" not in msg and "100.0 kB free" in msg and f"free {(need - 100_000) / 1e3:.1f} kB" \
        " more" in msg, msg
    assert path.read_bytes() == before
    assert sorted(q.name for q in tmp_path.iterdir()) == ["run.h5"]


def test_the_copy_estimate_bounds_a_real_copy(toy, tmp_path, monkeypatch):
    """The copy's size said in the message is within 25 % above what the copy takes."""
    _, stopped = toy
    path = tmp_path / "run.h5"
    shutil.copy(stopped, path)
    monkeypatch.setattr(recovery, "COPY_ROOM", 0)  # the copy, whatever the room
    need = recovery.copy_bytes(read_run(path))
    HDF5Store.open_append(path).close()
    took = os.path.getsize(path)
    assert Path(str(path) + ".crashed").exists()
    assert took <= need <= 1.25 * took, (took, need)


# --- a genuine full disk: a tmpfs (root only) --------------------------------------------


@pytest.fixture
def small_disk(tmp_path):
    """A tmpfs of 2000 kB at ``tmp_path / 'disk'`` and a function that resizes it (kB)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2000k", "tmpfs", str(disk)],
                       capture_output=True, text=True)
    if p.returncode:
        pytest.skip(f"cannot mount a tmpfs: {p.stderr.strip()}")

    def resize(kb: int) -> None:
        subprocess.run(["mount", "-o", f"remount,size={kb}k", str(disk)], check=True)

    yield disk, resize
    subprocess.run(["umount", "-l", str(disk)], check=False)


def _cli(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "pavement_mcmc", *args], capture_output=True,
                          text=True, cwd=REPO, env=env, timeout=600)


def test_resume_after_a_full_disk_with_less_room_than_a_copy(small_disk, tmp_path):
    """Case A fills a 2000 kB disk at 190 of its 330 steps (a 2.1 MB chain file); 1400 kB more
    (less than the chain file; the copy alone takes 1.3 MB and the run must grow past it) and
    ``resume`` ends as the undisturbed fit: before, "writing chain.h5.recovering failed"."""
    disk, resize = small_disk
    ref = tmp_path / "straight"
    assert _cli("fit", "runs/caseA.toml", "--out", str(ref)).returncode == 0
    run = disk / "run"
    p = _cli("fit", "runs/caseA.toml", "--out", str(run))
    assert p.returncode == 2 and "No space left on device" in p.stderr, p.stderr[-2000:]
    kept = read_run(run / "chain.h5").n_saved
    size = os.path.getsize(run / "chain.h5")
    assert 0 < kept < read_run(ref / "chain.h5").n_saved and size > 1400 * 1024
    resize(2000 + 1400)
    p = _cli("resume", str(run))
    assert p.returncode == 0, p.stderr[-2000:]
    assert _same(read_run(run / "chain.h5"), read_run(ref / "chain.h5"))
    for name in ("summary.csv", "summary.md"):
        assert (run / name).read_text() == (ref / name).read_text()
    assert not (run / "chain.h5.crashed").exists() and not (run / "chain.h5.recovering").exists()
