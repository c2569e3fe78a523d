"""Batch throughput on Dask: the same units with 1 and with 2 local workers, side by side.

``run(quick=False) -> list[dict]``: 12 (quick: 6) Case A-sized units (6 h windows of the
reference case every 1 h, two h pieces, ESS >= 200, 8 chains; a few seconds each) through
:func:`pavement_mcmc.batch.run_batch` on a warm local cluster of 1, then 2 single-threaded
worker processes (cluster start-up and the workers' first solver load are excluded: one warm-up
unit first). Prints units per minute, the 2-worker / 1-worker ratio, the mean wall time of a
unit inside a worker, its peak resident memory, and the machine's load average meanwhile (the
development machine is shared: a ratio below 2 often means the second core was busy).

``python benchmarks/bench_batch.py [--quick]``.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.batch import connect, run_batch, window_units  # noqa: E402

SMALL = {"model": {"h": {"kind": "uniform", "n": 2}},
         "sampler": {"ess_target": 200, "max_steps": 4000, "n_walkers": 8}}


def _units(n: int, offset: float = 0.0):
    wins = [(offset + i, offset + i + 6.0) for i in range(n)]
    return window_units(ROOT / "runs" / "caseA.toml", windows=wins, overrides=SMALL)


def run(quick: bool = False) -> list[dict]:
    n = 6 if quick else 12
    rows, rate = [], {}
    for workers in (1, 2):
        with connect(n_workers=workers) as client, tempfile.TemporaryDirectory() as tmp:
            run_batch(_units(workers, offset=20.0), Path(tmp) / "warm", client=client, seed=1)
            load0 = os.getloadavg()[0]
            t0 = time.perf_counter()
            out = run_batch(_units(n), Path(tmp) / "b", client=client, seed=1)
            wall = time.perf_counter() - t0
            recs = [json.loads((Path(tmp) / "b" / r["run_dir"] / "unit.json").read_text()) for r in out]
        rate[workers] = 60.0 * n / wall
        rows.append({
            "workers": workers, "units": n, "wall_s": wall, "units_per_min": rate[workers],
            "ratio_vs_1": rate[workers] / rate[1],
            "unit_s_mean": sum(r["elapsed_s"] for r in recs) / n,
            "peak_rss_mb": max(r["peak_rss_mb"] for r in recs),
            "converged": sum(r["status"] == "ok" for r in recs),
            "load_avg_1min": f"{load0:.1f}-{os.getloadavg()[0]:.1f}",
        })
    return rows


if __name__ == "__main__":
    from run_all import print_table

    print_table(run(quick="--quick" in sys.argv))
