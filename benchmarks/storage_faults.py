"""Storage faults, the "done when" figures of issue 24 (a few minutes on 2 cores).

1. Disk full at 10 sizes over a Case A and a Case C fit: the command line fit runs under
   ``RLIMIT_FSIZE`` (a genuine EFBIG, SIGXFSZ ignored), must exit 2 with one error line (no
   traceback, no crash), then ``resume`` (no limit) must end with the chain, log-posterior and
   Generator state of the uninterrupted run of the same seed; its file's size against the
   uninterrupted run's shows what the failed flush left allocated.
2. Truncation at 10 offsets and 10 single flipped bytes of the finished Case A chain file:
   ``read_run`` must refuse each (or, if the damage missed the run, read it identically), and
   ``diagnostics``, ``report``, ``diagnose``, ``compare``, ``export`` must refuse a refused file
   with one line naming it; a batch whose unfinished unit has a damaged chain redoes that unit
   and ends with the undisturbed ``batch.csv`` byte for byte.

``python benchmarks/storage_faults.py [OUT]`` prints one line per trial and a summary. The
scheduler killed 3 times during a batch is ``tests/batch/test_batch_scheduler.py`` (slow mark).
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.storage import StoreDamaged, read_run  # noqa: E402

LIMITED = ("import os, resource, signal, sys; l = int(sys.argv[1]); "
           "signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
           "resource.setrlimit(resource.RLIMIT_FSIZE, (l, l)); "
           "os.execv(sys.executable, [sys.executable, *sys.argv[2:]])")
#: fractions of the uninterrupted chain file's size at which the disk is full
FRACTIONS = (0.45, 0.6, 0.75, 0.88, 0.97)


def _cli(args: list[str], limit: int | None = None) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "pavement_mcmc", *args]
    if limit is not None:
        cmd = [sys.executable, "-c", LIMITED, str(limit), "-m", "pavement_mcmc", *args]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env, timeout=1800)


def _same(a, b) -> bool:
    return (a.n_saved == b.n_saved and a.state.rng_state == b.state.rng_state
            and all(np.array_equal(getattr(a, k), getattr(b, k))
                    for k in ("chain", "log_prob", "blobs", "accepted")))


def disk_full(out: Path) -> tuple[int, int, int]:
    clean = resumed = 0
    n = 0
    for case in ("caseA", "caseC"):
        ref = out / f"{case}_straight"
        assert _cli(["fit", f"runs/{case}.toml", "--out", str(ref)]).returncode == 0
        size = os.path.getsize(ref / "chain.h5")
        straight = read_run(ref / "chain.h5")
        for frac in FRACTIONS:
            n += 1
            run, limit = out / f"{case}_{frac}", int(size * frac)
            p = _cli(["fit", f"runs/{case}.toml", "--out", str(run)], limit)
            errors = [ln for ln in p.stderr.splitlines() if "error:" in ln]
            ok = (p.returncode == 2 and len(errors) == 1 and "Traceback" not in p.stderr
                  and "last committed step" in errors[0] and "free space" in errors[0])
            clean += ok
            kept = read_run(run / "chain.h5").n_saved
            r = _cli(["resume", str(run)])
            same = r.returncode == 0 and _same(read_run(run / "chain.h5"), straight)
            resumed += same
            grown = os.path.getsize(run / "chain.h5") / size
            print(f"disk full {case} at {limit} B ({frac:.0%}): exit {p.returncode}, "
                  f"{'clean' if ok else 'NOT CLEAN'}, {kept} of {straight.n_saved} steps kept; "
                  f"resume {'bit-identical' if same else 'DIFFERS'}, file {grown:.3f} x the "
                  f"uninterrupted run's\n    {errors[-1:]}", flush=True)
    return n, clean, resumed


def _damage(src: Path, dst: Path, kind: str, arg: float) -> None:
    shutil.copy(src, dst)
    if kind == "truncate":
        os.truncate(dst, int(os.path.getsize(src) * arg))
        return
    with open(dst, "r+b") as fh:
        fh.seek(int(arg))
        b = fh.read(1)
        fh.seek(int(arg))
        fh.write(bytes([b[0] ^ 0xFF]))


def _readers_refuse(bad: Path, good: Path, tmp: Path) -> bool:
    from pavement_mcmc.cli import main

    for cmd in (["diagnostics", str(bad)], ["report", str(bad)], ["diagnose", str(bad)],
                ["compare", str(good), str(bad)], ["export", str(bad), str(tmp / "x.csv")]):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(cmd)
        if code != 2 or f"{bad / 'chain.h5'} is damaged" not in err.getvalue():
            print(f"    {cmd[0]}: exit {code}: {err.getvalue()[-300:]}")
            return False
    return True


def damaged_files(out: Path) -> tuple[int, int, int, int, int]:
    good = out / "caseA_straight"
    size = os.path.getsize(good / "chain.h5")
    straight = read_run(good / "chain.h5")
    trials = [("truncate", f) for f in np.linspace(0.05, 0.95, 10)]
    trials += [("flip", o) for o in np.random.default_rng(24).integers(0, size, 10)]
    refused = intact = silent = readers = 0
    for kind, arg in trials:
        bad = out / "damaged"
        shutil.rmtree(bad, ignore_errors=True)
        shutil.copytree(good, bad)
        _damage(good / "chain.h5", bad / "chain.h5", kind, arg)
        try:
            run = read_run(bad / "chain.h5")
            outcome = "read intact" if _same(run, straight) else "SILENT MISREAD"
            intact += outcome == "read intact"
            silent += outcome != "read intact"
        except StoreDamaged as err:
            outcome, msg = "refused", str(err)
            refused += 1
            readers += _readers_refuse(bad, good, out)
        print(f"{kind} {arg:.3g}: {outcome}" + (f"\n    {msg[:160]}" if outcome == "refused" else ""),
              flush=True)
    return len(trials), refused, intact, silent, readers


def batch_redoes_a_damaged_unit(out: Path) -> bool:
    sys.path.insert(0, str(ROOT / "tests" / "batch"))
    from test_batch import KEYS, _units

    from pavement_mcmc.batch import TABLE, run_batch

    ref, b = out / "batch_ref", out / "batch"
    run_batch(_units(), ref, seed=5, n_workers=2)
    shutil.copytree(ref, b)
    (b / KEYS[1] / "unit.json").unlink()  # unfinished, and its chain cut
    _damage(ref / KEYS[1] / "chain.h5", b / KEYS[1] / "chain.h5", "truncate", 0.5)
    run_batch(_units(), b, seed=5, n_workers=2)
    return (b / TABLE).read_bytes() == (ref / TABLE).read_bytes()


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(tempfile.mkdtemp(prefix="storage_faults_"))
    out.mkdir(parents=True, exist_ok=True)
    n, clean, resumed = disk_full(out)
    t, refused, intact, silent, readers = damaged_files(out)
    batch = batch_redoes_a_damaged_unit(out)
    print(f"\ndisk full: {clean}/{n} clean exits, {resumed}/{n} resumes bit-identical")
    print(f"damaged chain files: {t} ({refused} refused, {intact} read intact, {silent} silent "
          f"misreads); the 5 readers refused {readers}/{refused} of the refused ones")
    print(f"batch with a damaged unfinished unit: batch.csv {'identical' if batch else 'DIFFERS'}")
    return 0 if clean == resumed == n and silent == 0 and readers == refused and batch else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
