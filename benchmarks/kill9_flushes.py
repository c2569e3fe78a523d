"""Writers killed by SIGKILL at random moments of their flushes: is every committed step kept?

Each trial starts a writer of a run with chunks of 8 steps of 256 kB (32 chains, 128
parameters), flushing 1 to 3 steps at a time and reporting each commit, kills it with SIGKILL
0.05 to 1 s after its first commit, then reads the file. A trial is "kept" when the file reads
with at least the steps last reported committed, every row exact; "refused" when the store
refuses the file (a torn chunk of committed rows fails its checksum: format 2 rewrote the chunk
holding the last committed rows at every flush); anything else is "wrong".

    python benchmarks/kill9_flushes.py [N_TRIALS]     # 225 by default, about 1.5 s a trial

Run with ``PYTHONPATH`` at an older checkout to measure its format the same way.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from pavement_mcmc.storage import HDF5Store, RunState
    m, p = 32, 128
    store = HDF5Store.create(sys.argv[1], [f"p{i}" for i in range(p)], [], m, {})
    rng, t = np.random.default_rng(int(sys.argv[2])), 0
    while True:
        for _ in range(int(rng.integers(1, 4))):
            x = t * 100.0 + np.arange(m)[:, None] * 10.0 + np.arange(p)
            store.append(x, np.full(m, -t), None, np.ones(m, bool))
            t += 1
        store.flush(RunState.capture(x, np.full(m, 1.0 - t), None, extra={"n": t}))
        print(t, flush=True)
    """
)


def trial(tmp: Path, k: int, wait: float) -> tuple[str, str]:
    """One writer killed ``wait`` s after its first commit: (outcome, detail)."""
    from pavement_mcmc.storage import StoreDamaged, read_run

    path = tmp / f"run{k}.h5"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), str(k)],
                            stdout=subprocess.PIPE, text=True)
    first = proc.stdout.readline()
    time.sleep(wait)
    proc.send_signal(signal.SIGKILL)
    rest = proc.stdout.read().split()
    proc.wait()
    reported = int(rest[-1]) if rest else int(first)
    try:
        run = read_run(path)
    except StoreDamaged as err:
        return "refused", f"{reported} reported; {err}"
    finally:
        path.unlink()
    t = np.arange(run.n_saved)[:, None, None]
    exact = np.array_equal(run.chain, t * 100.0 + np.arange(32)[None, :, None] * 10.0
                           + np.arange(128))
    if run.n_saved >= reported and exact and run.state.extra["n"] == run.n_saved:
        return "kept", f"{run.n_saved} steps ({reported} reported)"
    return "wrong", f"{run.n_saved} steps read, {reported} reported, rows exact: {exact}"


def main(n: int) -> int:
    from pavement_mcmc.storage import FORMAT_VERSION

    rng = np.random.default_rng(2026)
    counts = {"kept": 0, "refused": 0, "wrong": 0}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(n):
            outcome, detail = trial(Path(tmp), k, float(rng.uniform(0.05, 1.0)))
            counts[outcome] += 1
            if outcome != "kept":
                print(f"trial {k}: {outcome}: {detail}", flush=True)
    print(f"format {FORMAT_VERSION}: {n} writers killed by SIGKILL during flushes: "
          f"{counts['kept']} kept every committed step, {counts['refused']} refused, "
          f"{counts['wrong']} wrong")
    return 0 if counts["kept"] == n else 1


if __name__ == "__main__":
    if "PYTHONPATH" not in os.environ:  # this checkout, for this process and the writers
        os.environ["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
        sys.path.insert(0, os.environ["PYTHONPATH"])
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 225))
