"""``hmc`` from a start metric far too narrow or far too wide, with and without the guard of
``samplers/metric_guard.py``, beside the normal start, in one process.

Case A (``runs/caseA.toml``, its paper priors) sampled by ``hmc`` to the stopping rule, seeds
1-3, from its Laplace approximation (the normal start) and from the same with κ's row and column
of the covariance scaled by 1e-5 (too narrow) and by 1e3 (too wide; κ's sd that times the
Laplace one, its correlations kept; the start points are drawn from it too), each with the guard
on, off (``metric_guard.RATIO = inf``) and, too wide, on with one probe (``metric_guard.REFINE =
0``: no re-probe at the narrowed sd). Runs are capped at :data:`MAX_STEPS` steps. ``grad_x_normal``
is a run's gradients over the normal start's (guard on, same seed), ``off_over_on`` the guard-off
run's gradients over the guard-on run's of the same start and seed; ``dmean_z`` the largest
difference of a posterior mean from the normal start's in units of the normal run's posterior sd;
``sd_ratio`` the range of the posterior sds over the normal start's.

``python benchmarks/bench_metric_guard.py [--quick] [--wide]`` (quick: seed 1 only; wide: instead,
seed 1 from κ's sd 1e3 and 1e5 times the Laplace one, each run stopped after 60 s).
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem, find_map  # noqa: E402
from pavement_mcmc.runs import run_sampler  # noqa: E402
from pavement_mcmc.samplers import get_sampler, metric_guard  # noqa: E402
from pavement_mcmc.storage import MemoryStore  # noqa: E402

#: steps after which a run that has not met the stopping rule is stopped
MAX_STEPS = 20_000
#: κ's sd in the shrunk and in the widened start metric, relative to the Laplace one
SHRINK, WIDE = 1e-5, 1e3


def shrunk(lap, i: int, factor: float):
    """The Laplace approximation ``lap`` with parameter ``i``'s sd scaled by ``factor``
    (covariance and the working coordinates' covariance the start points are drawn from)."""
    f = np.ones(lap.cov.shape[0])
    f[i] = factor
    fz = f[lap.idx]
    return dataclasses.replace(lap, cov=lap.cov * np.outer(f, f), cov_z=lap.cov_z * np.outer(fz, fz))


#: guard settings: (RATIO, REFINE)
MODES = {"on": (10.0, 4), "one probe": (10.0, 0), "off": (np.inf, 4)}


def one(pr, lap, seed: int, mode: str, max_seconds: float | None = None) -> tuple[dict, np.ndarray]:
    metric_guard.RATIO, metric_guard.REFINE = MODES[mode]
    try:
        t0 = time.perf_counter()
        s = get_sampler("hmc", pr.posterior, n_chains=16, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s.prepare(laplace=lap)
        st = MemoryStore.create(pr.space.free, pr.posterior.blob_names, s.n_chains, {"sampler": "hmc"})
        res = run_sampler(s, st, ess_target=1000, max_steps=MAX_STEPS, max_seconds=max_seconds)
        wall = time.perf_counter() - t0
    finally:
        metric_guard.RATIO, metric_guard.REFINE = MODES["on"]
    kept = st.read().chain[res.burn_in:].reshape(-1, len(pr.space.free))
    return ({"seed": seed, "guard": mode, "converged": res.converged, "steps": res.n_steps,
             "gradients": res.n_evals, "wall_s": wall, "max_rhat": float(res.rhat.max()),
             "rescaled": int(np.sum(s.rescale != 1.0))}, kept)


def run(quick: bool = False, wide: bool = False) -> list[dict]:
    pr = build_problem(load_case(ROOT / "runs" / "caseA.toml"))
    pr.posterior.loglik_and_grad(pr.space.initial()[None])  # compile outside the timing
    lap = find_map(pr.posterior)
    k = pr.space.free.index("kappa")
    starts = [("normal", lap, ("on", "off"), None),
              (f"kappa sd x{SHRINK:g}", shrunk(lap, k, SHRINK), ("on", "off"), None),
              (f"kappa sd x{WIDE:g}", shrunk(lap, k, WIDE), ("on", "one probe", "off"), None)]
    if wide:
        starts = [("normal", lap, ("on",), None)] + [
            (f"kappa sd x{f:g}", shrunk(lap, k, f), ("on", "one probe", "off"), 60.0) for f in (1e3, 1e5)]
    rows = []
    for seed in (1,) if quick or wide else (1, 2, 3):
        ref = None
        for label, start, modes, max_seconds in starts:
            on = None
            for mode in modes:
                row, kept = one(pr, start, seed, mode, max_seconds)
                if ref is None:
                    ref, ref_grad = kept, row["gradients"]
                on = row["gradients"] if on is None else on
                m, sd = ref.mean(0), ref.std(0)
                r = kept.std(0) / sd
                rows.append({"start": label, **row, "grad_x_normal": row["gradients"] / ref_grad,
                             "off_over_on": row["gradients"] / on if mode == "off" else "",
                             "dmean_z": float(np.max(np.abs(kept.mean(0) - m) / sd)),
                             "sd_ratio": f"{r.min():.2f}-{r.max():.2f}"})
                print(rows[-1], flush=True)
    return rows


if __name__ == "__main__":
    from run_all import print_table

    print_table(run(quick="--quick" in sys.argv, wide="--wide" in sys.argv))
