"""Faults found by hand (29 Nov 2026) around a run's small files and its resume, each mended:

* a flipped byte in an object header of ``chain.h5``: ``resume`` (HDF5's own read-write open)
  waited for ever or crashed with a traceback, and wrote to the damaged file; it must refuse in
  one error and leave the file as it was;
* ``result.json`` cut short by a full disk: every reader stopped with a JSONDecodeError; the
  small files are now written whole or not at all (a real EFBIG below), a cut one is named,
  and ``resume`` writes it again from the chain;
* a kill after the last commit but before its stopping check: ``resume`` skipped the check and
  sampled past the step the run stops at (997 steps for 949: not bit for bit);
* a kill between ``result.json`` and ``summary.csv``: no summary ever again.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from pavement_mcmc.data import RunError
from pavement_mcmc.runs import load_view, resume
from pavement_mcmc.storage import StoreDamaged, read_run

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def run(finished_run, tmp_path) -> Path:
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    return out


def _flip(path: Path, offset: int) -> None:
    with open(path, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)
        fh.seek(offset)
        fh.write(bytes([b[0] ^ 16]))


@pytest.mark.parametrize("obj", ["chain", "commit", "writer"])
def test_resume_refuses_a_damaged_header_and_leaves_the_file_alone(run, obj):
    with h5py.File(run / "chain.h5", "r") as f:
        addr = h5py.h5o.get_info(f[obj].id).addr
    (run / "result.json").unlink()
    _flip(run / "chain.h5", addr + 10)
    before = (run / "chain.h5").read_bytes()
    with pytest.raises(StoreDamaged, match="is damaged"):
        resume(run)
    assert (run / "chain.h5").read_bytes() == before
    assert not (run / "chain.h5.crashed").exists()


def test_killed_after_the_last_commit_resumes_to_the_same_run(run, finished_run):
    """The stopping check of the last commit is done first on resume: same steps, same table."""
    for f in ("result.json", "summary.csv", "summary.md"):
        (run / f).unlink()
    out = resume(run)
    n = read_run(finished_run / "chain.h5").n_saved
    assert out.ran and out.result.converged and out.result.n_steps == n
    assert read_run(run / "chain.h5").n_saved == n
    assert (run / "summary.csv").read_text() == (finished_run / "summary.csv").read_text()


def test_a_cut_result_json_is_named_and_resume_writes_it_again(run, finished_run):
    whole = (run / "result.json").read_text()
    (run / "result.json").write_text(whole[: len(whole) // 3])
    with pytest.raises(RunError, match="result.json is damaged"):
        load_view(run)
    resume(run)
    again = json.loads((run / "result.json").read_text())
    timing = {k for k in again if "elapsed" in k or "seconds" in k}
    assert timing and {k: v for k, v in again.items() if k not in timing} == {
        k: v for k, v in json.loads(whole).items() if k not in timing}


def test_a_cut_result_json_is_kept_when_the_chain_is_damaged_too(run):
    (run / "result.json").write_text("{")
    with h5py.File(run / "chain.h5", "r") as f:
        addr = h5py.h5o.get_info(f["chain"].id).addr
    _flip(run / "chain.h5", addr + 10)
    with pytest.raises(StoreDamaged):
        resume(run)
    assert (run / "result.json").read_text() == "{"


def test_missing_summaries_of_a_finished_run_are_written_again(run, finished_run):
    for f in ("summary.csv", "summary.md"):
        (run / f).unlink()
    out = resume(run)
    assert not out.ran
    assert (run / "summary.csv").read_text() == (finished_run / "summary.csv").read_text()
    assert (run / "summary.md").is_file()


@pytest.mark.skipif(not hasattr(__import__("signal"), "SIGXFSZ"), reason="needs POSIX limits")
def test_a_write_over_the_file_size_limit_keeps_the_old_file(tmp_path):
    """A genuine EFBIG (RLIMIT_FSIZE in a child process): the old file stays whole, no
    temporary file is left, the error reaches the caller."""
    target = tmp_path / "report.html"
    target.write_text("old report\n")
    script = textwrap.dedent(f"""
        import errno, resource, signal, sys
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        from pavement_mcmc.storage import write_atomic
        try:
            write_atomic({str(target)!r}, "x" * 100_000)
        except OSError as err:
            sys.exit(7 if err.errno == errno.EFBIG else 1)
        """)
    rc = subprocess.run([sys.executable, "-c", script], env={**os.environ, "PYTHONPATH": str(REPO)},
                        timeout=120).returncode
    assert rc == 7
    assert target.read_text() == "old report\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]
    np.testing.assert_equal(len(target.read_bytes()), 11)
