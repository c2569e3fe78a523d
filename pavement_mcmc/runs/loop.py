"""The shared run loop: blocks of steps through one store, a stopping rule, progress.

The stopping rule is a :class:`~pavement_mcmc.diagnostics.StoppingRule` (its thresholds, its
defaults and its check live there); this loop decides when to check it:

* burn-in = the adaptation phase (``n_adapt`` steps: fast/mh tune their proposal, emcee none)
  plus the MSER-5 truncation point of the log-posterior after it; a fixed ``burn_in``
  overrides both (and is then also the adaptation length);
* the checks run at step counts fixed in advance (:data:`CHECK_FIRST`, :data:`CHECK_GROWTH`:
  a geometric schedule, so a run with a given seed stops at the same step on any machine and
  the diagnostics stay a small share of a long run's time); a check is skipped while the kept
  chain is shorter than :data:`SKIP_FRACTION` of the length the last check's tau requires;
  each stops at the first failing criterion; a run stopped by a budget gets one full check at
  the end;
* otherwise the run stops when ``max_steps`` (counted over the whole run, resumes included) or
  ``max_seconds`` (this invocation) runs out, with ``converged=False`` and the reason.

Every block is appended to the store and flushed with the sampler's full state, so an
interrupted run (Ctrl-C, ``kill -9``) loses at most the block in flight and a resume continues
bit for bit (the sampler's random stream does not depend on block boundaries).
Library code: nothing is printed; ``callback`` receives a dict after every block (steps, the
minimum ESS of the last check against ``ess_target``, the phase): the command line draws its
progress from it (:mod:`pavement_mcmc.cli.progress`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..diagnostics.stopping import Check, StoppingRule
from ..samplers import Sampler
from ..storage import Store

#: checks at fixed step counts: CHECK_FIRST steps after the adaptation, then whenever the step
#: count has grown by CHECK_GROWTH (at least CHECK_FIRST steps later), so where a run stops
#: depends on its seed only, never on the machine's speed, and the checks cost a bounded share.
#: A run overshoots the step its rule first holds at by up to CHECK_GROWTH - 1: at 1.15 (before
#: a failing check cost one parameter's autocorrelation, :meth:`StoppingRule.check` ``first``)
#: Case C seeds 1-6 took 846 k evaluations, at 1.05 768 k; grass/tutorial windows 4-5 % fewer
CHECK_FIRST, CHECK_GROWTH, SKIP_FRACTION = 20, 1.05, 0.7


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
    rule : the stopping rule the run was held to (diagnostics and the report apply the same one).
    n_adapt_rows : stored rows of the sampler's adaptation phase (never kept: burn-in >= this).
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
    rule: StoppingRule = StoppingRule()
    n_adapt_rows: int = 0


def _round_up(n: float, thin: int) -> int:
    return int(-(-int(np.ceil(n)) // thin) * thin)


class Rows:
    """The rows stored so far as a list of blocks: a check gathers only the (thinned) rows it
    uses instead of copying the whole chain (gigabytes on a long Case C run)."""

    def __init__(self):
        self.blocks: list[np.ndarray] = []
        self.starts: list[int] = []
        self.n = 0
        self._logp: list[np.ndarray] = []
        self._acc: list[np.ndarray] = []

    def add(self, chain: np.ndarray, logp: np.ndarray, accepted: np.ndarray) -> None:
        if chain.shape[0]:
            self.blocks.append(chain)
            self.starts.append(self.n)
            self.n += chain.shape[0]
            self._logp.append(logp)
            self._acc.append(accepted)

    def small(self) -> tuple[np.ndarray, np.ndarray]:
        """(log_prob, accepted) of every row, concatenated (cached as one block)."""
        for lst in (self._logp, self._acc):
            if len(lst) > 1:
                lst[:] = [np.concatenate(lst)]
        return self._logp[0], self._acc[0]

    def take(self, idx: np.ndarray, cols=None) -> np.ndarray:
        """Chain rows at increasing global indices ``idx`` (of the parameters ``cols`` only)."""
        idx = np.asarray(idx, int)
        bounds = np.searchsorted(idx, [*self.starts, self.n])
        pick = (lambda blk, i: blk[i]) if cols is None else (lambda blk, i: blk[:, :, cols][i])
        parts = [pick(blk, idx[a:b] - s) for blk, s, a, b in zip(self.blocks, self.starts, bounds[:-1],
                                                                  bounds[1:]) if b > a]
        return np.concatenate(parts) if parts else self.blocks[0][:0]


def run_sampler(
    sampler: Sampler,
    store: Store,
    *,
    rule: StoppingRule | None = None,
    ess_target: float | None = None,
    max_steps: int = 200_000,
    max_seconds: float | None = None,
    burn_in: int | None = None,
    n_adapt: int | None = None,
    thin: int = 1,
    block_seconds: float = 2.0,
    min_tau_lengths: float | None = None,
    rhat_max: float | None = None,
    min_steps: int = 0,
    callback: Callable[[dict], None] | None = None,
    check_due: bool = True,
) -> RunResult:
    """Run ``sampler`` into ``store`` until ``rule`` is met or the budget is out.

    ``rule`` defaults to :class:`~pavement_mcmc.diagnostics.StoppingRule`'s defaults;
    ``ess_target``, ``min_tau_lengths`` and ``rhat_max`` replace its thresholds when given.
    The sampler is prepared (``store`` empty) or restored from ``store.state`` (resume: the
    stored rows are read back). ``burn_in`` and ``n_adapt`` are in steps (adaptation defaults
    to the sampler's ``adapt_length``, or ``burn_in``); every ``thin``-th step is stored; no
    stop on convergence before ``min_steps``. ``check_due``: a resumed run whose last commit's
    check never ran (killed between the two; no ``result.json``) does it before sampling on.
    Returns a :class:`RunResult`.
    """
    t0 = time.perf_counter()
    rule = (rule or StoppingRule()).with_overrides(
        ess_target=ess_target, min_tau_lengths=min_tau_lengths, rhat_max=rhat_max)
    thin = int(thin)
    n_adapt, n_adapt_rows, burn_rows = _adaptation(sampler, burn_in, n_adapt, thin)
    rows, loop_state = _stored(store)
    n_steps = int(loop_state.get("n_steps", 0))
    n_evals = int(loop_state.get("n_evals", sampler.n_prep_evals))
    names = list(store.param_names)

    block, check, converged = max(thin, 10 // thin * thin), None, False
    next_check = int(loop_state.get("next_check", _round_up(n_adapt + CHECK_FIRST, thin)))
    # a kept chain shorter than SKIP_FRACTION x min_tau_lengths x (last tau_max) cannot pass:
    # such a check is skipped (the skip depends on the chain only, so runs stay reproducible)
    hint = loop_state.get("hint", [0, 0.0])  # [burn-in rows, tau_max] of the last check
    min_ess = None  # the smallest ESS the last checks estimated (the progress line's)
    first = loop_state.get("first")  # the parameter that held the last check (its ESS or R-hat)
    reason = ""

    def quick_check():
        nonlocal check, hint, converged, min_ess, first, reason
        check = rule.check(rows, *rows.small(), n_adapt_rows, burn_rows, names, full=False,
                           first=first)
        hint, converged = _hint(check, hint), not check.failures
        min_ess = _min_ess(check, min_ess)
        first = check.held_by if check.held_by is not None else first
        reason = rule.met_text() if converged else reason

    if check_due and loop_state.get("due") and n_steps >= min_steps:
        quick_check()  # killed between a commit and its check: the check first, as the run would
    while not converged:
        reason = _budget_out(n_steps, max_steps, max_seconds, time.perf_counter() - t0)
        if reason:
            break
        adapt = n_steps < n_adapt
        todo = _todo(block, n_steps, max_steps, n_adapt, min_steps, next_check, thin)
        tb = time.perf_counter()
        b = sampler.step(todo, adapt=adapt)
        dt = time.perf_counter() - tb
        _append(store, rows, b, thin)
        n_steps += todo
        n_evals += b.n_evals
        due = False
        if not adapt and n_steps >= next_check:  # a check point: check unless it cannot pass
            next_check = _round_up(max(n_steps + CHECK_FIRST, CHECK_GROWTH * n_steps), thin)
            due = rows.n - hint[0] >= SKIP_FRACTION * rule.min_tau_lengths * hint[1]
        state = sampler.get_state()
        state.extra["loop"] = {"n_steps": n_steps, "n_evals": n_evals, "n_adapt": n_adapt,
                               "thin": thin, "next_check": next_check, "hint": hint,
                               "first": first, "due": bool(due and n_steps >= min_steps)}
        store.flush(state)
        block = _next_block(todo, dt, time.perf_counter() - t0, block_seconds, thin)
        if due and n_steps >= min_steps:
            quick_check()
        if callback is not None:
            callback({"n_steps": n_steps, "n_evals": n_evals, "n_adapt": n_adapt,
                      "max_steps": max_steps, "adapting": adapt,
                      **_progress(rule, min_ess, b, time.perf_counter() - t0, check)})
        if converged:
            break
    if not converged and n_steps >= n_adapt and rows.n:
        # stopped by a budget: one full check of everything sampled, for the report
        check = rule.check(rows, *rows.small(), n_adapt_rows, burn_rows, names, full=True)
        converged = not check.failures and n_steps >= min_steps
        reason += ("; converged: " + rule.met_text()) if converged else ""
    return _outcome(rule, check, converged, reason, n_steps, rows.n, n_evals,
                    time.perf_counter() - t0, n_adapt_rows)


def _progress(rule: StoppingRule, min_ess: float | None, b, elapsed: float,
              check: Check | None = None) -> dict:
    """The callback's view of the last block and check (min ESS against the target, and what
    held the last check: once the ESS is met a run may wait on R-hat, drift or Geweke)."""
    return {"ess_target": rule.ess_target, "acceptance": float(b.accepted.mean()),
            "min_ess": min_ess, "elapsed": elapsed,
            "held": check.failures[0] if check is not None and check.failures else None}


def _min_ess(check: Check, last: float | None) -> float | None:
    """The smallest ESS a check estimated: of every parameter, or of the one a quick check
    failed on (an upper bound of the smallest); after a quick check that failed on R-hat, the
    last one known."""
    if not np.isnan(check.ess).any():
        return float(np.min(check.ess))
    j = check.held_by
    if j is not None and np.isnan(check.rhat[j]):  # a quick check ended by that one's ESS
        return float(check.ess[j])
    return last


def _hint(check: Check, last: list) -> list:
    """[burn-in rows, tau_max] of a check: the next check is skipped while it cannot pass. A
    quick check estimated one parameter's tau: the larger of it and the last known tau_max."""
    if np.isnan(check.tau).any():
        tau = check.tau[~np.isnan(check.tau)]
        tau_max = max(float(np.max(tau)) if tau.size else 0.0, float(last[1]))
    else:
        tau_max = float(np.max(check.tau))
    return [int(check.burn_in), tau_max if np.isfinite(tau_max) else 0.0]


def _budget_out(n_steps: int, max_steps: int, max_seconds: float | None, elapsed: float) -> str:
    """Why the run must stop now ("" while the budgets last)."""
    if n_steps >= max_steps:
        return f"step budget exhausted ({max_steps} steps)"
    if max_seconds is not None and elapsed >= max_seconds:
        return f"time budget exhausted ({max_seconds:g} s)"
    return ""


def _adaptation(sampler: Sampler, burn_in: int | None, n_adapt: int | None,
                thin: int) -> tuple[int, int, int | None]:
    """(adaptation steps, rounded up to ``thin``; its stored rows; a fixed burn-in in rows)."""
    if n_adapt is None:
        n_adapt = burn_in if burn_in is not None else sampler.adapt_length()
    if not sampler.adaptive:
        n_adapt = 0
    n_adapt = -(-int(n_adapt) // thin) * thin
    burn_rows = None if burn_in is None else -(-int(burn_in) // thin)
    return n_adapt, n_adapt // thin, burn_rows


def _stored(store: Store) -> tuple[Rows, dict]:
    """The rows already in ``store`` (a resume) and the loop's saved counters."""
    rows = Rows()
    if store.n_saved:
        data = store.read()
        rows.add(data.chain, data.log_prob, data.accepted)
    st = store.state
    return rows, (dict(st.extra.get("loop", {})) if st is not None else {})


def _todo(block: int, n_steps: int, max_steps: int, n_adapt: int, min_steps: int,
          next_check: int, thin: int) -> int:
    """Steps of the next block: never past the budget, the end of the adaptation, ``min_steps``
    or the next check point; a multiple of ``thin``."""
    todo = min(block, max_steps - n_steps)
    if n_steps < n_adapt:
        todo = min(todo, n_adapt - n_steps)
    if n_steps < min_steps:
        todo = min(todo, min_steps - n_steps)
    if n_steps < next_check:  # end the block on the check point
        todo = min(todo, next_check - n_steps)
    return max(thin, todo // thin * thin)


def _append(store: Store, rows: Rows, b, thin: int) -> None:
    """Every ``thin``-th step of block ``b`` into the store and the loop's rows."""
    sel = slice(thin - 1, None, thin)
    for th, lp, bl, acc in zip(b.chain[sel], b.logp[sel], b.blobs[sel], b.accepted[sel]):
        store.append(th, lp, bl, acc)
    rows.add(b.chain[sel], b.logp[sel], b.accepted[sel])


def _next_block(todo: int, dt: float, elapsed: float, block_seconds: float, thin: int) -> int:
    """Aim for blocks of ~block_seconds, but at most a quarter of the time so far, so a short
    run is not overshot by a long block before its first check."""
    target = min(block_seconds, max(0.1, 0.25 * elapsed))
    block = int(np.clip(todo * target / max(dt, 1e-4), thin, 5000)) // thin * thin
    return max(block, thin)


def _outcome(rule: StoppingRule, check, converged: bool, reason: str, n_steps: int,
             n_saved: int, n_evals: int, elapsed: float, n_adapt_rows: int) -> RunResult:
    """The :class:`RunResult` of a finished loop (the reason completed by the last check)."""
    if check is not None and check.failures and not converged:
        reason += "; not converged: " + "; ".join(check.failures)
    elif check is None and not converged:
        reason += "; not converged: still adapting"
    return RunResult(
        converged=converged, reason=reason, n_steps=n_steps, n_saved=n_saved,
        burn_in=check.burn_in if check is not None else n_saved, n_evals=n_evals,
        elapsed=elapsed,
        ess=check.ess if check else np.zeros(0), tau=check.tau if check else np.zeros(0),
        rhat=check.rhat if check else np.zeros(0),
        acceptance=check.acceptance if check else float("nan"),
        drifting=check.drifting if check else False,
        rule=rule, n_adapt_rows=int(n_adapt_rows),
    )
