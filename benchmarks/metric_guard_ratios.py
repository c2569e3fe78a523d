"""The start-metric guard on the shipped cases (samplers/metric_guard.py; docs/VALIDATION.md
section 2): per case under ``hmc`` (seed 1), each parameter's ratio of the posterior's
conditional sd to the start metric's, as the guard computes it before it rescales: with the
slope (the widening test: above RATIO widens) and with the curvature alone (the narrowing
test: below 1/RATIO narrows). Nothing below 1/RATIO means a normal start is not narrowed.

    PYTHONPATH=. python benchmarks/metric_guard_ratios.py [REPO]
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(sys.argv[1]) if sys.argv[1:] else Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402
from pavement_mcmc.samplers import get_sampler  # noqa: E402
from pavement_mcmc.samplers import metric_guard as guard  # noqa: E402
from pavement_mcmc.samplers.target import cholesky_of  # noqa: E402

CASES = [("caseA", None), ("caseB", None), ("caseC", None), ("hidden", None),
         ("hidden", "two_layer"), ("desert_plain", None), ("desert_plain", "two_layer"),
         ("desert", None), ("grass_plain", None), ("grass_plain", "surface_layer"),
         ("grass", None), ("grass_energy", None), ("desert_energy", None)]
_seen: dict = {}
_rescaled = guard.rescaled


def _recording(cov, X, f, G, *args, **kw):
    """``rescaled`` that first keeps the two ratios of its first call on a case."""
    prec_m = np.sum(np.linalg.inv(cholesky_of(cov)) ** 2, axis=0)
    with np.errstate(all="ignore"):
        curv = -(np.diag(G[1:]) - G[0]) / np.diag(X[1:] - X[0])
        _seen.setdefault("slope", np.sqrt(prec_m / np.maximum(curv, G[0] ** 2)))
        _seen.setdefault("curvature", np.sqrt(prec_m / curv))
    return _rescaled(cov, X, f, G, *args, **kw)


def main() -> None:
    guard.rescaled = _recording
    for name, ext in CASES:
        t0 = time.perf_counter()
        _seen.clear()
        add = {"model": {"extensions": [ext]}} if ext else None
        pr = build_problem(load_case(ROOT / "runs" / f"{name}.toml", additions=add))
        s = get_sampler("hmc", pr.posterior, n_chains=16, seed=1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s.prepare()
        names = [pr.space.free[i] for i in s.idx]
        out = []
        for key in ("slope", "curvature"):
            r = _seen[key]
            j, k = int(np.nanargmin(r)), int(np.nanargmax(r))
            out.append(f"{key} {r[j]:.3g} ({names[j]}) .. {r[k]:.3g} ({names[k]})")
        print(f"{name}{'+' + ext if ext else ''}: d = {len(names)}; " + "; ".join(out)
              + f"; {time.perf_counter() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
