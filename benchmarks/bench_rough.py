"""``hmc`` with and without the rough-scale moves (option ``rough_moves``, issue 25) on one case.

    python benchmarks/bench_rough.py CASE ROUGH_MOVES SEED [STEPS]

Without STEPS: to the stopping rule, printing the steps, the evaluations (gradients and the
moves' solves), the CPU seconds of preparation and sampling, the smallest ESS, and the checks'
failures (with the parameter of the largest split-R-hat). With STEPS: that many steps (the
adaptation included), printing the ESS of gamma, the smallest ESS and the largest split-R-hat of
the steps after 200, per 1000 gradient-equivalents (a solve counted as 1/3.7 of a gradient, its
cost at 16 sets) and per CPU second.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc import diagnostics as dg  # noqa: E402
from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.diagnostics import StoppingRule  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402
from pavement_mcmc.runs import run_sampler  # noqa: E402
from pavement_mcmc.samplers import get_sampler  # noqa: E402
from pavement_mcmc.samplers import hmc as hmc_module  # noqa: E402
from pavement_mcmc.storage import MemoryStore  # noqa: E402

#: a solve's cost in gradients (bench_gradient: 0.45 against 1.05 ms at 16 sets; 1/3.7 in the solver)
SOLVE_IN_GRADIENTS = 1 / 3.7


def main(case: str, rough: int, seed: int, steps: int | None) -> None:
    warnings.simplefilter("ignore")
    solves, checks = [0], []
    moves = hmc_module.scale_moves

    def counted(*a, **k):
        out = moves(*a, **k)
        solves[0] += out[4]
        return out

    hmc_module.scale_moves = counted
    check = StoppingRule.check

    def logged(self, rows, *a, **k):
        c = check(self, rows, *a, **k)
        r = np.nan_to_num(c.rhat, nan=0.0)
        checks.append((rows.n, [str(f)[:40] for f in c.failures], names[int(np.argmax(r))]))
        return c

    StoppingRule.check = logged
    pr = build_problem(load_case(ROOT / "runs" / f"{case}.toml"))
    names = pr.space.free
    pr.posterior.loglik_and_grad(pr.space.initial()[None])  # compile outside the timing
    opts = {**(pr.cfg.sampler.get("options") or {}), "rough_moves": rough}
    c0 = time.process_time()
    s = get_sampler("hmc", pr.posterior, seed=seed, options=opts)
    s.prepare()
    c1 = time.process_time()
    st = MemoryStore.create(names, pr.posterior.blob_names, s.n_chains, {"sampler": "hmc"})
    res = run_sampler(s, st, ess_target=1e12 if steps else 1000, max_steps=steps or 10**7)
    c2 = time.process_time()
    head = (f"{case} rough_moves={rough} seed={seed}: {res.n_steps} steps, {res.n_evals} evaluations "
            f"({solves[0]} of them the moves' solves), CPU prepare {c1 - c0:.1f} s, "
            f"sampling {c2 - c1:.1f} s")
    if not steps:
        print(f"{head}, converged {res.converged}, min ESS {res.ess.min():.0f}")
        for c in checks:
            print("  check", c)
        return
    kept = st.read().chain[200:]
    e, rh = dg.ess(kept), dg.split_rhat(kept)
    geq = res.n_evals - s.n_prep_evals - solves[0] * (1 - SOLVE_IN_GRADIENTS)
    gi = names.index("gamma") if "gamma" in names else int(np.argmin(e))
    print(f"{head}; after step 200: ESS gamma {e[gi]:.0f}, min {e.min():.0f} ({names[int(np.argmin(e))]}), "
          f"max split-R-hat {rh.max():.4f}; min ESS per 1000 gradient-equivalents "
          f"{1000 * e.min() / geq:.1f}, per CPU s {e.min() / (c2 - c1):.0f}")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(a[0], int(a[1]), int(a[2]), int(a[3]) if len(a) > 3 else None)
