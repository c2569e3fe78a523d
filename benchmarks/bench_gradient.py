"""Gradient benchmark on Case C (the paper's set-up: 114 free parameters, 28 h of 15-min data).

For batches of 16 and 32 parameter sets near the MAP it times, in the same process, the
log-posterior alone (one solve per set), its gradient by the solver's adjoint
(``LogPosterior.loglik_and_grad``: a solve plus a reverse sweep per set) and the same gradient
by central differences (``2 n_free + 1`` solves per set, the fallback for models without an
adjoint), and checks that the two gradients agree. Times are medians of repeats after a warm-up.
Beside the adjoint gradient it times, in the same process, the same gradient through the generic
NumPy observation path (``generic_grad_ms``: the compiled temperature path of
:mod:`pavement_mcmc.posterior.compiled` switched off) and checks the two are bit-identical;
these two are process CPU times, minima over rounds timed in turn (robust to a busy machine),
as are the solver's own share (``solver_solve_ms``: one solve; ``solver_solve_vjp_ms``: a solve
with its reverse sweep, the kernels of a gradient; ``solver_share``: that over the whole
adjoint gradient; the rest is Python around the kernels).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402
from pavement_mcmc.solver import solve, solve_vjp  # noqa: E402


def _median_time(fn, repeats: int) -> float:
    fn()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return float(np.median(out))


def _paired(fa, fb, repeats: int) -> tuple[float, float]:
    """Process CPU seconds per call of ``fa`` and ``fb``, each the minimum over ``repeats``
    rounds of 10 calls timed in turn (side by side: a busy machine slows both alike)."""
    fa(), fb()
    best = [np.inf, np.inf]
    for _ in range(repeats):
        for k, fn in enumerate((fa, fb)):
            t0 = time.process_time()
            for _ in range(10):
                fn()
            best[k] = min(best[k], (time.process_time() - t0) / 10)
    return best[0], best[1]


def run(quick: bool = False) -> list[dict]:
    pr = build_problem(load_case(ROOT / "runs" / "caseC.toml"))
    post = pr.posterior
    generic = build_problem(load_case(ROOT / "runs" / "caseC.toml")).posterior
    generic.streams[0].compiled_applies = lambda model: False  # the NumPy path, as before
    grid, forcing = post.model.grid, post.model.forcing
    rng = np.random.default_rng(0)
    theta0 = post.space.initial()
    theta0[post.space.free.index("kappa")] = 1.4
    theta0[post.space.free.index("C")] = 1.98e6
    rows = []
    for n in (16, 32):
        theta = theta0 * (1.0 + 0.01 * rng.standard_normal((n, theta0.size)))
        reps = 5 if quick else 15
        t_lp = _median_time(lambda th=theta: post(th), reps)
        t_adj, t_gen = _paired(lambda th=theta: post.loglik_and_grad(th, "adjoint"),
                               lambda th=theta: generic.loglik_and_grad(th, "adjoint"), 4 * reps)
        # the solver alone: a solve, and a solve with its reverse sweep (the gradient's kernels)
        coeffs = post.model.coefficients(post.space.expand(theta))
        zero = np.zeros((n, grid.n_obs, grid.n_nodes))
        t_solve, t_vjp = _paired(lambda c=coeffs: solve(grid, forcing, c),
                                 lambda c=coeffs, z=zero: solve_vjp(grid, forcing, c, lambda o: z), 4 * reps)
        same = all(np.array_equal(a, b) for a, b in zip(post.loglik_and_grad(theta, "adjoint"),
                                                        generic.loglik_and_grad(theta, "adjoint"),
                                                        strict=True))
        t_fd = _median_time(lambda th=theta: post.loglik_and_grad(th, "fd"), max(3, reps // 3))
        g_adj = post.loglik_and_grad(theta, "adjoint")[1]
        g_fd = post.loglik_and_grad(theta, "fd")[1]
        scale = np.abs(g_adj).max(axis=0) + 1e-12
        rows.append({"sets": n, "logpost_ms": 1e3 * t_lp, "adjoint_grad_ms": 1e3 * t_adj,
                     "generic_grad_ms": 1e3 * t_gen, "generic/compiled": t_gen / t_adj,
                     "bit_identical": same, "solver_solve_ms": 1e3 * t_solve,
                     "solver_solve_vjp_ms": 1e3 * t_vjp, "solver_share": t_vjp / t_adj,
                     "fd_grad_ms": 1e3 * t_fd, "adjoint/logpost": t_adj / t_lp,
                     "fd/adjoint": t_fd / t_adj,
                     "max_rel_diff": float(np.max(np.abs(g_adj - g_fd) / scale))})
    return rows


if __name__ == "__main__":
    from run_all import print_table

    print_table(run(quick="--quick" in sys.argv))
