"""Storage faults injected for real, without root (issue 24): a write over the file-size limit
(``RLIMIT_FSIZE`` set in a subprocess: a genuine EFBIG from the kernel), a truncated copy and
flipped bytes of a chain file. What must hold: one clear error and a clean exit (no traceback,
no crash), the last commit readable, a resume bit-identical to an uninterrupted run, and no
damaged file ever read as data."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.storage import HDF5Store, StoreDamaged, read_run

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(not hasattr(__import__("signal"), "SIGXFSZ"),
                                reason="needs POSIX resource limits")

#: run a command with RLIMIT_FSIZE = argv[1] bytes; SIGXFSZ ignored, so a write past the limit
#: fails with EFBIG instead of killing the process (what a full disk does, with ENOSPC)
LIMITED = textwrap.dedent(
    """
    import os, resource, signal, sys
    limit = int(sys.argv[1])
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    os.execv(sys.executable, [sys.executable, *sys.argv[2:]])
    """
)

#: a writer of a toy chain (rows drawn from the stored Generator, so a resume continues it);
#: it creates the file or continues it, up to argv[2] rows, in blocks of 7
WRITER = textwrap.dedent(
    f"""
    import sys
    sys.path.insert(0, {str(Path(__file__).resolve().parent)!r})
    from toy_writer import write
    write(sys.argv[1], int(sys.argv[2]))
    """
)


def _run(args: list[str], limit: int | None, tmp: Path, **kw) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    cmd = [sys.executable, *args]
    if limit is not None:
        (tmp / "limited.py").write_text(LIMITED)
        cmd = [sys.executable, str(tmp / "limited.py"), str(limit), *args]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=REPO, timeout=300, **kw)


def _same_rows(a, b, n: int) -> bool:
    return all(np.array_equal(getattr(a, k)[:n], getattr(b, k)[:n])
               for k in ("chain", "log_prob", "blobs", "accepted"))


@pytest.fixture(scope="module")
def toy(tmp_path_factory) -> Path:
    """An uninterrupted toy run of 700 rows (about 1.1 MB)."""
    tmp = tmp_path_factory.mktemp("toy")
    (tmp / "writer.py").write_text(WRITER)
    assert _run([str(tmp / "writer.py"), str(tmp / "straight.h5"), "700"], None, tmp).returncode == 0
    return tmp / "straight.h5"


@pytest.mark.parametrize("limit", [500_000, pytest.param(900_000, marks=pytest.mark.slow)])
def test_a_write_past_the_file_size_limit_stops_cleanly_and_resumes_bit_for_bit(toy, tmp_path, limit):
    straight = read_run(toy)
    (tmp_path / "writer.py").write_text(WRITER)
    path = tmp_path / "run.h5"
    p = _run([str(tmp_path / "writer.py"), str(path), "700"], limit, tmp_path)
    assert p.returncode == 3, p.stderr[-2000:]  # the writer's own exit: no crash (139), no kill
    assert "Traceback" not in p.stderr and "Segmentation" not in p.stderr, p.stderr[-2000:]
    out = json.loads(p.stdout)
    assert "File too large (errno 27)" in out["error"] and "last committed step" in out["error"]
    assert 0 < out["n_saved"] < 700 and os.path.getsize(path) <= limit
    kept = read_run(path)  # the last commit is whole: exactly the straight run's first rows
    assert kept.n_saved == out["n_saved"] and _same_rows(kept, straight, kept.n_saved)
    p = _run([str(tmp_path / "writer.py"), str(path), "700"], None, tmp_path)  # space freed
    assert p.returncode == 0, p.stderr[-2000:]
    final = read_run(path)
    assert final.n_saved == straight.n_saved and _same_rows(final, straight, final.n_saved)
    assert final.state.rng_state == straight.state.rng_state
    assert Path(str(path) + ".crashed").exists()  # the short file is kept beside


def _truncated(src: Path, dst: Path, frac: float) -> Path:
    shutil.copy(src, dst)
    os.truncate(dst, int(os.path.getsize(src) * frac))
    return dst


def _flipped(src: Path, dst: Path, offset: int) -> Path:
    shutil.copy(src, dst)
    with open(dst, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)
        fh.seek(offset)
        fh.write(bytes([b[0] ^ 0xFF]))
    return dst


def test_a_truncated_or_flipped_chain_file_is_refused_never_read_as_data(toy, tmp_path):
    straight = read_run(toy)
    size = os.path.getsize(toy)
    outcomes = []
    cases = [(_truncated, f) for f in np.linspace(0.05, 0.95, 10)]
    cases += [(_flipped, int(o)) for o in np.random.default_rng(7).integers(0, size, 10)]
    for make, arg in cases:
        path = make(toy, tmp_path / "bad.h5", arg)
        try:
            run = read_run(path)
        except StoreDamaged as err:
            assert str(path) in str(err) and "damaged" in str(err)
            if make is _truncated:
                assert "truncated" in str(err)
            outcomes.append("refused")
            continue
        # read: only if the damage missed everything the run is made of
        assert run.n_saved == straight.n_saved and _same_rows(run, straight, run.n_saved), \
            (make.__name__, arg)
        assert run.state.rng_state == straight.state.rng_state
        outcomes.append("intact")
    assert outcomes[:10] == ["refused"] * 10  # every cut is noticed
    assert outcomes.count("refused") >= 15, outcomes


def test_resume_of_a_damaged_file_refuses_and_leaves_it_alone(toy, tmp_path):
    path = _truncated(toy, tmp_path / "run.h5", 0.6)
    before = path.read_bytes()
    with pytest.raises(StoreDamaged, match="truncated"):
        HDF5Store.open_append(path)
    assert path.read_bytes() == before and not Path(str(path) + ".crashed").exists()


# --- the command line, on Case A ------------------------------------------------------------

SHORT = ["--set", "sampler.max_steps=150"]


@pytest.fixture(scope="module")
def case_a(tmp_path_factory):
    """Case A cut short by a 1 MB file-size limit, then resumed; and the same run straight."""
    from pavement_mcmc.runs import fit, resume

    tmp = tmp_path_factory.mktemp("caseA_full")
    run = tmp / "cut"
    p = _run(["-m", "pavement_mcmc", "fit", "runs/caseA.toml", "--out", str(run), *SHORT],
             1_000_000, tmp)
    resume(run)
    fit(REPO / "runs" / "caseA.toml", tmp / "straight", overrides={"sampler": {"max_steps": 150}})
    return p, run, tmp / "straight"


def test_cli_fit_on_a_full_disk_says_one_line_and_resume_continues_bit_for_bit(case_a):
    p, run, straight = case_a
    assert p.returncode == 2, p.stderr[-3000:]
    assert "Traceback" not in p.stderr and "bug" not in p.stderr, p.stderr[-3000:]
    errors = [ln for ln in p.stderr.splitlines() if "error:" in ln]
    assert len(errors) == 1, p.stderr[-3000:]
    line = errors[0]
    for part in ("chain.h5 failed: File too large", "last committed step", "a step",
                 f"free space, then 'pavement-mcmc resume {run}'"):
        assert part in line, line
    a, b = read_run(run / "chain.h5"), read_run(straight / "chain.h5")
    assert a.n_saved == b.n_saved == 150 and _same_rows(a, b, 150)
    assert a.state.rng_state == b.state.rng_state
    assert json.loads((run / "result.json").read_text())["n_steps"] == 150


@pytest.mark.parametrize("command", ["diagnostics", "report", "diagnose", "compare", "export"])
def test_every_reader_refuses_a_damaged_run_in_one_line(case_a, tmp_path, command, capsys):
    from pavement_mcmc.cli import main

    _, run, straight = case_a
    bad = tmp_path / "bad"
    shutil.copytree(straight, bad)
    _truncated(straight / "chain.h5", bad / "chain.h5", 0.5)
    args = {"compare": [str(straight), str(bad)], "export": [str(bad), str(tmp_path / "x.csv")]}
    code = main([command, *args.get(command, [str(bad)])])
    err = capsys.readouterr().err
    assert code == 2 and f"{bad / 'chain.h5'} is damaged: it is truncated" in err, err
    assert "Traceback" not in err and not (tmp_path / "x.csv").exists()


def test_the_reason_of_a_failed_write_is_one_line_in_the_systems_words():
    """HDF5's messages run over several lines and vary (a Case C fit over the limit said
    'Unable to extend file properly, ...' across two lines): the reason is the errno's text."""
    from pavement_mcmc.storage.integrity import system_reason

    err = RuntimeError("Unable to synchronously flush file (Unable to extend file properly, "
                       "errno = 27, error message = 'file too large' (file write failed: time = "
                       "Fri Nov 27 11:23:56 2026\n, filename = 'chain.h5', file descriptor = 3))")
    assert system_reason(err) == "File too large (errno 27)"
    assert system_reason(OSError(28, "x")) == "No space left on device (errno 28)"
    assert system_reason(RuntimeError("first\nsecond")) == "first"


#: flip a byte inside every object header of a run (addresses from HDF5 itself) and read it
FLIP_HEADERS = textwrap.dedent(
    """
    import json, shutil, sys, time
    import h5py
    from pavement_mcmc.storage import StoreDamaged, read_run
    import numpy as np
    src, dst = sys.argv[1], sys.argv[2]
    straight = read_run(src)
    with h5py.File(src, "r") as f:
        addrs = {}
        f.visititems(lambda name, obj: addrs.update({name: h5py.h5o.get_info(obj.id).addr}))
    out = {}
    for name, addr in sorted(addrs.items()):
        shutil.copy(src, dst)
        with open(dst, "r+b") as fh:
            fh.seek(addr + 24)
            b = fh.read(1)
            fh.seek(addr + 24)
            fh.write(bytes([b[0] ^ 0xFF]))
        t = time.perf_counter()
        try:
            run = read_run(dst)
            same = all(np.array_equal(getattr(run, k), getattr(straight, k))
                       for k in ("chain", "log_prob", "blobs", "accepted"))
            what = "read intact" if same and run.state.rng_state == straight.state.rng_state \
                else "read altered"
        except StoreDamaged as err:
            what = "refused: " + str(err)
        out[name] = [what, time.perf_counter() - t]
    print(json.dumps(out))
    """
)


def test_a_damaged_object_header_is_refused_in_seconds_not_waited_on(toy, tmp_path):
    """A SWMR reader retried a metadata block failing its checksum 100 times, waiting about
    2^k ns before attempt k: a flipped byte in a dataset's object header kept `read_run`
    waiting for hours (storage/swmr.py). Now each is refused within 5 s, or read whole when the
    commit does not use it (the other state slot)."""
    (tmp_path / "flip.py").write_text(FLIP_HEADERS)
    p = _run([str(tmp_path / "flip.py"), str(toy), str(tmp_path / "bad.h5")], None, tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    assert len(out) >= 10 and {"chain", "commit", "state/json0"} <= set(out), out
    for name, (what, seconds) in out.items():
        assert what == "read intact" or (what.startswith("refused") and "damaged" in what), \
            (name, what)
        assert seconds < 5, (name, seconds)
    refused = {name for name, (what, _) in out.items() if what.startswith("refused")}
    assert {"chain", "log_prob", "blobs", "accepted", "commit"} <= refused, out


#: load a second copy of h5py's HDF5 (another wheel's, or the system's, would do the same), then
#: open a run for reading and print the metadata read attempts in force on the open file
TWO_HDF5 = textwrap.dedent(
    """
    import ctypes, glob, json, os, shutil, sys
    import h5py
    libs = os.path.join(os.path.dirname(h5py.__file__), os.pardir, "h5py.libs")
    ours = [p for p in glob.glob(libs + "/libhdf5-*") if "_hl" not in os.path.basename(p)]
    if not ours:
        print(json.dumps({"skip": "h5py has no bundled libhdf5 here"}))
        sys.exit(0)
    shutil.copy(ours[0], sys.argv[2])  # another path, another copy of the library in memory
    other = ctypes.CDLL(sys.argv[2])
    from pavement_mcmc.storage.swmr import READ_ATTEMPTS, open_swmr_reader
    with open_swmr_reader(sys.argv[1]) as f:
        fapl = f.id.get_access_plist()
        n = ctypes.c_uint(0)
        ok = ctypes.CDLL(ours[0]).H5Pget_metadata_read_attempts(ctypes.c_int64(fapl.id),
                                                                ctypes.byref(n))
    print(json.dumps({"ok": ok, "attempts": n.value, "expected": READ_ATTEMPTS}))
    """
)


def h5py_file() -> str:
    import h5py

    return h5py.__file__


@pytest.fixture
def first_sorting_dir(tmp_path):
    """A directory whose path sorts before h5py's own: the pytest temporary directory when it
    does (/tmp against a venv under /work), else one made beside h5py in site-packages (a CI
    checkout under /check sorts before /tmp), removed afterwards."""
    h5py_dir = Path(h5py_file()).parent
    if str(tmp_path) < str(h5py_dir):
        yield tmp_path
        return
    import tempfile

    try:
        d = Path(tempfile.mkdtemp(prefix="!pm-", dir=h5py_dir.parent))
    except OSError as err:
        pytest.skip(f"no directory sorting before {h5py_dir} can be written: {err}")
    assert str(d) < str(h5py_dir)
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


def test_the_read_attempts_are_set_in_h5pys_hdf5_with_another_hdf5_loaded(toy, tmp_path,
                                                                          first_sorting_dir):
    """swmr.py took the first libhdf5 in the memory map: with another one loaded (here a copy of
    h5py's own, at a path sorting first), it called that library with h5py's property list,
    which failed, and the reader kept HDF5's 100 attempts (hours on a damaged header)."""
    copy = first_sorting_dir / "libhdf5-other.so"
    assert str(copy) < str(Path(h5py_file()).parent)  # the copy's path is met first
    (tmp_path / "two.py").write_text(TWO_HDF5)
    p = _run([str(tmp_path / "two.py"), str(toy), str(copy)], None, tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    if "skip" in out:
        pytest.skip(out["skip"])
    assert out["ok"] >= 0 and out["attempts"] == out["expected"] == 28, (out, p.stderr[-2000:])


#: cut a run at each given offset and read it, timing each read
CUT = textwrap.dedent(
    """
    import json, os, shutil, sys, time
    from pavement_mcmc.storage import StoreDamaged, read_run
    src, dst, offsets = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    out = []
    for off in offsets:
        shutil.copy(src, dst)
        os.truncate(dst, off)
        t = time.perf_counter()
        try:
            read_run(dst)
            what = "read"
        except StoreDamaged as err:
            what = "refused: " + str(err)
        out.append([off, what, time.perf_counter() - t])
        print(json.dumps(out[-1]), flush=True)
    """
)


def test_a_truncated_run_of_format_3_is_refused_in_seconds(toy, tmp_path):
    """A truncated file of format 3 once kept a SWMR reader waiting (HDF5's 100 metadata read
    attempts, bounded in storage/swmr.py): cuts at 12 sizes and inside the chunks of each
    tail slot and row dataset, read in a subprocess (killed after 5 minutes): each refused in
    under 5 s."""
    import h5py

    size = os.path.getsize(toy)
    offsets = {int(size * f) for f in np.linspace(0.04, 0.98, 12)}
    with h5py.File(toy, "r") as f:
        assert f.attrs["format_version"] == 3 and f["chain"].shape[0] > 0
        for name in ("chain", "tail/chain", "tail/log_prob", "state/json0"):
            for i in range(f[name].id.get_num_chunks()):
                info = f[name].id.get_chunk_info(i)
                offsets.add(int(info.byte_offset + info.size // 2))
    (tmp_path / "cut.py").write_text(CUT)
    p = _run([str(tmp_path / "cut.py"), str(toy), str(tmp_path / "cut.h5"),
              json.dumps(sorted(offsets))], None, tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    out = [json.loads(ln) for ln in p.stdout.splitlines()]
    assert len(out) == len(offsets) >= 16
    for off, what, seconds in out:
        assert what.startswith("refused") and "truncated" in what, (off, what)
        assert seconds < 5, (off, seconds)
