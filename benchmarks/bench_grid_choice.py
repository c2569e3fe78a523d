"""The grid ``[grid] kind = "auto"`` chooses for the plain 72-h field windows against the former
default (``Grid.stretched``'s defaults, ``[grid] kind = "stretched"``), in the same process:

1. the ladder the choice climbed (max sensor difference / sigma against the 2x refined grid);
2. the shift of the gamma-marginal MAP of kappa and C, in Laplace sd;
3. the CPU time of a gradient (16 sets, ``loglik_and_grad``), with one numba thread and with
   numba's default threads (the load average is printed: on a busy machine the threads wait).

``PYTHONPATH=. python benchmarks/bench_grid_choice.py [grass_plain desert_plain]``; needs the
shared records (``../shared/data``).
"""

from __future__ import annotations

import os
import sys
import time
import warnings
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402
from pavement_mcmc.samplers.target import MarginalTarget  # noqa: E402

GRIDS = (("former default", {"grid": {"kind": "stretched"}}), ("chosen", {}))


def cpu_ms_per_gradient(pb, reps: int = 6, calls: int = 10, sets: int = 16) -> float:
    """Median over ``reps`` of the CPU time of ``calls`` gradient calls of ``sets`` sets, per set."""
    X = np.repeat(pb.space.initial()[None], sets, axis=0)
    pb.posterior.loglik_and_grad(X)
    out = []
    for _ in range(reps):
        c = time.process_time()
        for _ in range(calls):
            pb.posterior.loglik_and_grad(X)
        out.append((time.process_time() - c) / (calls * sets) * 1e3)
    return float(np.median(out))


def map_kappa_c(pb) -> dict:
    """The gamma-marginal MAP of kappa and C and their Laplace sd."""
    tg = MarginalTarget(pb.posterior)
    free, cov = list(pb.space.free), np.asarray(tg.mmap.cov)
    out = {}
    for name in ("kappa", "C"):
        i = free.index(name)
        j = list(tg.idx).index(i)
        out[name] = (float(tg.mmap.theta[i]), float(np.sqrt(cov[j, j])))
    return out


def main(cases: list[str]) -> None:
    warnings.simplefilter("ignore")
    threads = numba.get_num_threads()
    for case in cases or ["grass_plain", "desert_plain"]:
        rows = {}
        for label, ov in GRIDS:
            pb = build_problem(load_case(ROOT / "runs" / f"{case}.toml", ov))
            g = pb.model.grid
            numba.set_num_threads(1)
            one = cpu_ms_per_gradient(pb)
            numba.set_num_threads(threads)
            many = cpu_ms_per_gradient(pb)
            rows[label] = map_kappa_c(pb)
            print(f"{case}, {label}: {g.n_nodes} nodes x {int(g.substeps.max())} steps per "
                  f"interval; CPU per gradient {one:.3f} ms (1 thread), {many:.3f} ms ({threads} "
                  f"threads); load {os.getloadavg()[0]:.1f}", flush=True)
            if pb.grid_chosen:
                print(f"  why: {pb.grid_chosen['why']}")
        for name in ("kappa", "C"):
            (a, _), (b, sd) = rows["chosen"][name], rows["former default"][name]
            print(f"  MAP {name}: {a:.6g} against {b:.6g}, shift {(a - b) / sd:+.4f} Laplace sd")


if __name__ == "__main__":
    main(sys.argv[1:])
