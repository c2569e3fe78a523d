"""Is a run's Geweke failure real? The stopping rule's Geweke test on principal components
(diagnostics/stationarity.py: the variance of each segment's mean from an AR spectral density at
zero, on the pooled chains) against the same early-late difference judged by the independent
chains themselves (one difference per chain, a t statistic with n_chains - 1 degrees of
freedom, which needs no model of the autocorrelation), at several burn-ins.

    PYTHONPATH=. python benchmarks/geweke_chains.py RUN [burn_in ...]
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.stats import t as student

from pavement_mcmc.diagnostics.stationarity import GEWEKE_ROWS, geweke_verdict
from pavement_mcmc.storage import read_run


def chain_t(x: np.ndarray, first: float = 0.1, last: float = 0.5) -> np.ndarray:
    """Per principal component (ordered as ``geweke_components`` orders them), the t statistic
    of the chains' (early mean - late mean)."""
    flat = x.reshape(-1, x.shape[2])
    sd = flat.std(axis=0)
    moving = sd > 0
    y = (x[:, :, moving] - flat[:, moving].mean(axis=0)) / sd[moving]
    e, V = np.linalg.eigh(np.atleast_2d(np.cov(y.reshape(-1, y.shape[2]), rowvar=False)))
    pc = y @ V[:, e > 1e-10 * e.max()]
    n = pc.shape[0]
    d = pc[: max(1, int(first * n))].mean(axis=0) - pc[n - int(last * n):].mean(axis=0)
    return d.mean(axis=0) / (d.std(axis=0, ddof=1) / np.sqrt(d.shape[0]))


def main(run: str, burn_ins: list[int]) -> None:
    chain = read_run(f"{run}/chain.h5").chain
    print(f"{run}: {chain.shape[0]} steps x {chain.shape[1]} chains x {chain.shape[2]} parameters")
    crit = student.ppf(0.975, chain.shape[1] - 1)
    for b in burn_ins:
        x = chain[b:]
        v = geweke_verdict(x)
        sub = x[:: max(1, -(-x.shape[0] // GEWEKE_ROWS))]
        t = chain_t(sub)
        print(f"burn-in {b:>6d}: the rule's AR z, components beyond 1.96: {v.n_fail_components} of "
              f"{v.zc.size} (max |z| {np.max(np.abs(v.zc)):.2f}; {'fails' if v.failed else 'passes'});"
              f" the chains' t beyond {crit:.2f}: {int(np.sum(np.abs(t) > crit))} "
              f"(max |t| {np.max(np.abs(t)):.2f})")


if __name__ == "__main__":
    main(sys.argv[1], [int(a) for a in sys.argv[2:]] or [150, 1000, 2000, 4000, 8000])
