"""How well ``hmc``'s starting metric (the guarded Laplace covariance at the MAP, in the
sampler's working coordinates) matches a finished run's posterior: each parameter's posterior sd
over the metric's, and the variances of the posterior along the metric's whitened directions
(all near 1 for a metric the trajectories fit; one far above 1 is a direction the Laplace
curvature makes too narrow, which the trajectories cross in a random walk).

    PYTHONPATH=. python benchmarks/metric_ridge.py RUN [first_kept_step]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.storage import read_run


def main(run: Path, first: int | None) -> None:
    cfg = load_case(run / "case.toml")
    pb = build_problem(cfg)
    sampler = cfg.sampler
    s = get_sampler("hmc", pb.posterior, n_chains=sampler.get("n_walkers") or 16,
                    seed=sampler.get("seed"), options=sampler.get("options", {}))
    s.prepare()
    chain = read_run(run / "chain.h5").chain
    kept = chain[(chain.shape[0] // 2 if first is None else first):].reshape(-1, chain.shape[-1])
    P = np.cov(s.coords.to_w(kept[:, s.idx]).T)
    Li = np.linalg.inv(s.L)
    ratios = np.linalg.eigvalsh(Li @ P @ Li.T)
    sd = np.sqrt(np.diag(P) / np.diag(s.L @ s.L.T))
    print("posterior sd / metric sd: " + ", ".join(
        f"{n} {x:.2f}" for n, x in zip(np.array(pb.space.free)[s.idx], sd, strict=True)))
    print("posterior variance along the metric's whitened directions: "
          + " ".join(f"{x:.3g}" for x in np.sort(ratios)))


if __name__ == "__main__":
    main(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else None)
