"""A genuine full disk, then ``resume`` with less room freed than a copy of the chain (root only).

For each size a tmpfs is mounted, Case A is fitted into it until the disk is full, the tmpfs is
made ``FREED`` kB larger (less than the chain file), and ``resume`` is run (if it fills the disk
again, once more with ``MORE`` kB more): it must end with the
undisturbed fit's steps, rows, Generator and summaries, without a ``.crashed`` or
``.recovering`` file. Printed per size: the steps kept, the chain file's size and blocks, the
free space before ``resume``, and the outcome.

``sudo python benchmarks/full_disk_resume.py [OUT]`` (about 10 s a size on 2 cores).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.storage import read_run  # noqa: E402

#: tmpfs sizes at which the fit fills the disk, and the room then freed (kB)
SIZES = tuple(int(s) for s in os.environ.get("SIZES", "1600 1800 2000 2200 2400").split())
FREED = 1400
#: more room given when the first resume filled the disk again (kB)
MORE = 600


def _cli(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "pavement_mcmc", *args], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=1800)


def _same(a, b) -> bool:
    return (a.n_saved == b.n_saved and a.state.rng_state == b.state.rng_state
            and all(np.array_equal(getattr(a, k), getattr(b, k))
                    for k in ("chain", "log_prob", "blobs", "accepted")))


def one(out: Path, ref: Path, kb: int) -> bool:
    disk = out / f"disk{kb}"
    disk.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={kb}k", "tmpfs", str(disk)], check=True)
    try:
        run = disk / "run"
        p = _cli("fit", "runs/caseA.toml", "--out", str(run))
        chain = run / "chain.h5"
        kept, size = read_run(chain).n_saved, os.path.getsize(chain)
        subprocess.run(["mount", "-o", f"remount,size={kb + FREED}k", str(disk)], check=True)
        free = shutil.disk_usage(disk).free
        r = _cli("resume", str(run))
        again = r.returncode == 2 and "No space left on device" in r.stderr
        if again:  # the run's growth and the failed block's blocks did not fit: more room
            subprocess.run(["mount", "-o", f"remount,size={kb + FREED + MORE}k", str(disk)],
                           check=True)
            r = _cli("resume", str(run))
        same = r.returncode == 0 and _same(read_run(chain), read_run(ref / "chain.h5")) and all(
            (run / n).read_text() == (ref / n).read_text() for n in ("summary.csv", "summary.md"))
        extra = sorted(q.name for q in run.iterdir() if q.name.startswith("chain.h5."))
        blocks = os.stat(chain).st_blocks * 512
        print(f"tmpfs {kb} kB: fit exit {p.returncode}, {kept} steps kept, chain {size} B; "
              f"{free} B free for resume: {f'full again, {MORE} kB more, ' if again else ''}"
              f"exit {r.returncode}, "
              f"{'identical' if same else 'DIFFERS'}, extra files {extra}, chain {blocks} B "
              f"of blocks{'' if r.returncode == 0 else chr(10) + '    ' + r.stderr[-300:]}",
              flush=True)
        return same and not extra
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def main(argv: list[str]) -> int:
    if os.geteuid() != 0:
        print("needs root (it mounts tmpfs file systems)")
        return 2
    out = Path(argv[0]) if argv else Path(tempfile.mkdtemp(prefix="full_disk_"))
    out.mkdir(parents=True, exist_ok=True)
    ref = out / "straight"
    assert _cli("fit", "runs/caseA.toml", "--out", str(ref)).returncode == 0
    print(f"undisturbed: {read_run(ref / 'chain.h5').n_saved} steps, chain "
          f"{os.path.getsize(ref / 'chain.h5')} B")
    ok = sum(one(out, ref, kb) for kb in SIZES)
    print(f"\n{ok}/{len(SIZES)} resumed in place, identical to the undisturbed fit")
    return 0 if ok == len(SIZES) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
