"""The shared run loop: blocks of steps through one store, a stopping rule, progress.

Rule (checked after every block once adaptation is over):

* burn-in = the adaptation phase (``n_adapt`` steps: fast/mh tune their proposal, emcee none)
  plus the MSER-5 truncation point of the chain-averaged log-posterior after it
  (:func:`~pavement_mcmc.diagnostics.choose_burn_in`); a fixed ``burn_in`` overrides both (and
  is then also the adaptation length);
* converged when, on the kept chain, every parameter has ESS >= ``ess_target``, the chain is at
  least ``min_tau_lengths`` (50) integrated autocorrelation times long, every split-R-hat is
  below ``rhat_max`` (1.01) and the mean log-posterior is not drifting
  (:func:`~pavement_mcmc.diagnostics.is_drifting`);
* the check runs after a block only when the sampling since the previous check took at least
  :data:`CHECK_COST_RATIO` times that check's cost (diagnostics stay a small fraction of the
  wall time on long, high-dimensional runs), and stops at the first failing criterion; a run
  stopped by a budget gets one full check at the end;
* otherwise the run stops when ``max_steps`` (counted over the whole run, resumes included) or
  ``max_seconds`` (this invocation) runs out, with ``converged=False`` and the reason.

Every block is appended to the store and flushed with the sampler's full state, so an
interrupted run (Ctrl-C, ``kill -9``) loses at most the block in flight and a resume continues
bit for bit (the sampler's random stream does not depend on block boundaries).
Library code: nothing is printed; ``progress=True`` shows a tqdm bar on stderr and ``callback``
receives a dict after every block.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .. import diagnostics as dg
from ..storage import Store
from .base import Sampler

#: default adaptation length per sampler (steps), as a function of the dimension
#: rows (after thinning) on which a convergence check estimates tau and split-R-hat
TAU_ROWS, RHAT_ROWS = 2000, 1000
#: a check runs only when the sampling since the previous one took >= this many times its cost
CHECK_COST_RATIO = 4.0

DEFAULT_ADAPT = {"fast": lambda d: max(150, 10 * d), "mh": lambda d: max(2000, 50 * d),
                 "emcee": lambda d: 0}


@dataclass
class RunResult:
    """Outcome of :func:`run_sampler`.

    Attributes
    ----------
    converged : every stopping criterion met.
    reason : a plain sentence: why the run stopped.
    n_steps : steps taken in total (all invocations); ``n_saved`` rows stored (``thin``).
    burn_in : stored rows discarded as burn-in.
    n_evals : posterior evaluations (solves) in total, preparation included.
    elapsed : seconds of this invocation.
    ess, tau, rhat : per parameter on the kept chain (tau in stored rows).
    acceptance : mean acceptance on the kept chain.
    drifting : the kept log-posterior still trends.
    """

    converged: bool
    reason: str
    n_steps: int
    n_saved: int
    burn_in: int
    n_evals: int
    elapsed: float
    ess: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tau: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rhat: np.ndarray = field(default_factory=lambda: np.zeros(0))
    acceptance: float = float("nan")
    drifting: bool = False


@dataclass
class Check:
    burn_in: int
    ess: np.ndarray
    tau: np.ndarray
    rhat: np.ndarray
    acceptance: float
    drifting: bool
    failures: list


def check_convergence(chain: np.ndarray, logp: np.ndarray, accepted: np.ndarray, n_adapt_rows: int,
                      burn_in: int | None = None, ess_target: float = 1000.0,
                      min_tau_lengths: float = 50.0, rhat_max: float = 1.01,
                      names: list[str] | None = None, full: bool = True) -> Check:
    """Apply the stopping rule to stored rows (see the module docstring).

    The estimates use the kept chain thinned to at most :data:`TAU_ROWS` rows (tau, ESS, drift)
    and :data:`RHAT_ROWS` rows (split-R-hat; the rank normalisation sorts every draw), which
    keeps a check cheap next to the sampling. With ``full=False`` the check stops at the
    first failing criterion in the order ESS / length (cheap), drift, R-hat (the costly one):
    the run loop uses that while the chain is still short; unevaluated R-hats are ``nan``.
    """
    if burn_in is None:
        rest = logp[n_adapt_rows:]
        extra = dg.choose_burn_in(rest) if rest.shape[0] >= 20 else 0
        burn_in = n_adapt_rows + extra
    kept = chain[burn_in:]
    p = chain.shape[2]
    names = names or [f"p{i}" for i in range(p)]
    if kept.shape[0] < 8:
        return Check(burn_in, np.zeros(p), np.full(p, np.inf), np.full(p, np.inf), float("nan"),
                     False, [f"only {kept.shape[0]} kept steps"])
    k = max(1, kept.shape[0] // TAU_ROWS)
    tau = dg.integrated_time(kept[::k], tol=0, quiet=True) * k
    ess = kept.shape[0] * kept.shape[1] / tau
    acc = float(np.mean(accepted[burn_in:]))
    fails = []
    if not np.all(ess >= ess_target):
        fails.append(f"ESS {ess.min():.0f} < {ess_target:g} ({names[int(np.argmin(ess))]})")
    if not kept.shape[0] >= min_tau_lengths * np.max(tau):
        fails.append(f"kept chain {kept.shape[0]} < {min_tau_lengths:g} x tau_max {np.max(tau):.1f}")
    drifting = dg.is_drifting(logp[burn_in:][::k])
    if drifting:
        fails.append("log-posterior still drifting")
    rhat = np.full(p, np.nan)
    if full or not fails:
        rhat = dg.split_rhat(kept[:: max(1, kept.shape[0] // RHAT_ROWS)])
        if not np.all(rhat < rhat_max):
            fails.append(f"R-hat {np.nanmax(rhat):.3f} >= {rhat_max}")
    return Check(burn_in, ess, tau, rhat, acc, drifting, fails)


def _merged(rows: list) -> tuple:
    """Concatenate the (chain, logp, accepted) blocks in place (one block left) and return it."""
    if len(rows) > 1:
        rows[:] = [tuple(np.concatenate([r[i] for r in rows]) for i in range(3))]
    return rows[0]


def run_sampler(
    sampler: Sampler,
    store: Store,
    *,
    ess_target: float = 1000.0,
    max_steps: int = 200_000,
    max_seconds: float | None = None,
    burn_in: int | None = None,
    n_adapt: int | None = None,
    thin: int = 1,
    block_seconds: float = 2.0,
    min_tau_lengths: float = 50.0,
    rhat_max: float = 1.01,
    progress: bool = False,
    callback: Callable[[dict], None] | None = None,
) -> RunResult:
    """Run ``sampler`` into ``store`` until converged or out of budget.

    The sampler must be prepared (fresh run, ``store`` empty) or restored with
    :meth:`Sampler.set_state` from ``store.state`` (resume; the rows already in ``store`` are
    read back for the diagnostics). ``burn_in`` and ``n_adapt`` are in steps; the adaptation
    length defaults to :data:`DEFAULT_ADAPT` (or to ``burn_in`` when given). Steps are
    stored every ``thin``-th step. Returns a :class:`RunResult`.
    """
    t0 = time.perf_counter()
    thin = int(thin)
    if n_adapt is None:
        n_adapt = burn_in if burn_in is not None else DEFAULT_ADAPT.get(
            sampler.name, lambda d: 0)(sampler.ndim)
    if not sampler.adaptive:
        n_adapt = 0
    n_adapt = -(-int(n_adapt) // thin) * thin
    n_adapt_rows = n_adapt // thin
    burn_rows = None if burn_in is None else -(-int(burn_in) // thin)

    data = store.read() if store.n_saved else None
    rows = [] if data is None else [(data.chain, data.log_prob, data.accepted)]
    st = store.state
    loop_state = dict(st.extra.get("loop", {})) if st is not None else {}
    n_steps = int(loop_state.get("n_steps", 0))
    n_evals = int(loop_state.get("n_evals", sampler.n_prep_evals))
    names = list(store.param_names)

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=max_steps, initial=n_steps, unit="step", dynamic_ncols=True, leave=True)
    block = max(thin, 10 // thin * thin)
    check = None
    reason = ""
    converged = False
    check_cost = since_check = 0.0  # seconds: last check, sampling since then
    try:
        while True:
            if n_steps >= max_steps:
                reason = f"step budget exhausted ({max_steps} steps)"
                break
            if max_seconds is not None and time.perf_counter() - t0 >= max_seconds:
                reason = f"time budget exhausted ({max_seconds:g} s)"
                break
            adapt = n_steps < n_adapt
            todo = min(block, max_steps - n_steps)
            if adapt:
                todo = min(todo, n_adapt - n_steps)
            todo = max(thin, todo // thin * thin)
            tb = time.perf_counter()
            b = sampler.step(todo, adapt=adapt)
            dt = time.perf_counter() - tb
            sel = slice(thin - 1, None, thin)
            for th, lp, bl, acc in zip(b.chain[sel], b.logp[sel], b.blobs[sel], b.accepted[sel]):
                store.append(th, lp, bl, acc)
            n_steps += todo
            n_evals += b.n_evals
            rows.append((b.chain[sel], b.logp[sel], b.accepted[sel]))
            state = sampler.get_state()
            state.extra["loop"] = {"n_steps": n_steps, "n_evals": n_evals, "n_adapt": n_adapt,
                                   "thin": thin}
            store.flush(state)
            # aim for blocks of ~block_seconds, but at most a quarter of the time so far, so a
            # short run is not overshot by a long block before its first check
            target = min(block_seconds, max(0.1, 0.25 * (time.perf_counter() - t0)))
            block = int(np.clip(todo * target / max(dt, 1e-4), thin, 5000)) // thin * thin
            block = max(block, thin)
            since_check += dt
            if not adapt and n_steps >= n_adapt and since_check >= CHECK_COST_RATIO * check_cost:
                tc = time.perf_counter()
                check = check_convergence(*_merged(rows), n_adapt_rows, burn_rows, ess_target,
                                          min_tau_lengths, rhat_max, names, full=False)
                check_cost, since_check = time.perf_counter() - tc, 0.0
                if not check.failures:
                    converged = True
                    reason = (f"ESS >= {ess_target:g} for every parameter, kept chain"
                              f" >= {min_tau_lengths:g} tau, R-hat < {rhat_max}, no drift")
                    break
            info = {"n_steps": n_steps, "n_evals": n_evals, "acceptance": float(b.accepted.mean()),
                    "adapting": adapt,
                    "min_ess": None if check is None else float(np.min(check.ess))}
            if bar is not None:
                bar.update(todo)
                bar.set_postfix(acc=f"{info['acceptance']:.2f}",
                                ess="adapting" if adapt else f"{info['min_ess'] or 0:.0f}")
            if callback is not None:
                callback(info)
    finally:
        if bar is not None:
            bar.close()
    if not converged and n_steps >= n_adapt and rows:
        # stopped by a budget: one full check of everything sampled, for the report
        check = check_convergence(*_merged(rows), n_adapt_rows, burn_rows, ess_target,
                                  min_tau_lengths, rhat_max, names, full=True)
    if check is not None and check.failures and not converged:
        reason += "; not converged: " + "; ".join(check.failures)
    elif check is None and not converged:
        reason += "; not converged: still adapting"
    n_saved = sum(r[0].shape[0] for r in rows)
    return RunResult(
        converged=converged, reason=reason, n_steps=n_steps, n_saved=n_saved,
        burn_in=check.burn_in if check is not None else n_saved, n_evals=n_evals,
        elapsed=time.perf_counter() - t0,
        ess=check.ess if check else np.zeros(0), tau=check.tau if check else np.zeros(0),
        rhat=check.rhat if check else np.zeros(0),
        acceptance=check.acceptance if check else float("nan"),
        drifting=check.drifting if check else False,
    )
