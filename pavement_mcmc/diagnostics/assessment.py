"""The convergence assessment of a stored run: per-parameter pass/fail and a run-level verdict."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .burnin import trend_z
from .stationarity import GEWEKE_Z, geweke_verdict
from .stopping import StoppingRule
from .summarize import summary


@dataclass
class Assessment:
    """Per-parameter diagnostics and the run-level verdict.

    Attributes
    ----------
    table : ``{name: {mean, sd, q2.5, q50, q97.5, tau, ess, rhat, geweke_rel, geweke_z,
        passed}}``.
    acceptance : overall acceptance after burn-in.
    acceptance_walkers : (n_chains,) per walker.
    burn_in, n_steps, n_kept, n_chains : chain lengths.
    drifting : does the kept log-posterior still trend (|z| > 3)?
    trend_z : the trend statistic.
    trusted : the verdict.
    reasons : why not (empty when trusted).
    warnings : concerns that do not by themselves fail the run.
    """

    table: dict[str, dict[str, float]]
    acceptance: float
    acceptance_walkers: np.ndarray
    burn_in: int
    n_steps: int
    n_kept: int
    n_chains: int
    drifting: bool
    trend_z: float
    trusted: bool
    reasons: list[str]
    warnings: list[str]
    rule: StoppingRule = StoppingRule()
    #: None for a run that finished by its rule, else why it is unfinished
    unfinished: str | None = None
    #: stored rows of the sampler's adaptation (a burn-in never ends inside it)
    n_adapt_rows: int = 0

    def to_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k != "acceptance_walkers"}
        d["acceptance_walkers"] = self.acceptance_walkers.tolist()
        d["rule"] = self.rule.to_dict()
        return d

    def verdict_text(self) -> str:
        if self.trusted:
            return (f"The run can be trusted: it finished by its stopping rule "
                    f"({self.rule.text()})" + ("." if self.rule.geweke else
                                               ", and Geweke finds no more early/late "
                                               "differences than chance."))
        return "The run can NOT be trusted yet: " + " ".join(self.reasons)


def assess(run, burn_in: int, rule: StoppingRule | None = None,
           unfinished: str | None = None, n_adapt_rows: int = 0) -> Assessment:
    """Convergence diagnostics of a stored run after ``burn_in`` steps.

    A parameter passes if the kept chain is at least ``rule.min_tau_lengths`` integrated
    autocorrelation times long, its ESS is at least ``rule.ess_target``, split-R-hat <
    ``rule.rhat_max`` and Geweke's |z| < 1.96 (``rule``: the
    :class:`~pavement_mcmc.diagnostics.StoppingRule` the run was sampled under, its defaults
    when not given). ``burn_in`` must not end inside the ``n_adapt_rows`` stored rows of the
    sampler's adaptation. A run that did not finish by its rule
    (``unfinished``: why) is never trusted. The run is trusted if
    none fails the other checks, no walker is stuck, the kept log-posterior does not drift and
    Geweke's test on the chain's principal components (uncorrelated, unlike the parameters:
    :func:`~pavement_mcmc.diagnostics.geweke_components`) fails for at most 10 % of them (5 %
    by chance) with no |z| above 3.5.

    emcee's walkers are not independent chains: ESS and split-R-hat across walkers are
    optimistic approximations; the IACT criterion is the primary one.
    """
    chain = run.chain
    n, m, p = chain.shape
    kept = chain[burn_in:]
    names = list(run.param_names)
    nk = kept.shape[0]
    rule = rule or StoppingRule()
    ess_min, rhat_max, tau_factor = rule.ess_target, rule.rhat_max, rule.min_tau_lengths
    reasons: list[str] = [f"the run is unfinished: {unfinished}."] if unfinished else []
    warns: list[str] = []
    if burn_in < n_adapt_rows:
        raise ValueError(f"burn-in {burn_in} ends inside the adaptation ({n_adapt_rows} rows)")
    if nk < 8:
        raise ValueError(f"only {nk} steps after a burn-in of {burn_in}: too short to diagnose")
    summ = summary(kept, names)
    table = {}
    n_fail_gew = []
    for name in names:
        s = dict(summ[name])
        ok_tau = np.isfinite(s["tau"]) and nk >= tau_factor * s["tau"]
        ok_ess = s["ess"] >= ess_min
        ok_rhat = np.isfinite(s["rhat"]) and s["rhat"] < rhat_max
        ok_gew = np.isfinite(s["geweke_z"]) and abs(s["geweke_z"]) < GEWEKE_Z
        s.update(tau_ok=bool(ok_tau), ess_ok=bool(ok_ess), rhat_ok=bool(ok_rhat),
                 geweke_ok=bool(ok_gew), passed=bool(ok_tau and ok_ess and ok_rhat and ok_gew))
        table[name] = s
        if not ok_gew:
            n_fail_gew.append(name)
    acc = np.asarray(run.accepted[burn_in:], float)
    acc_w = acc.mean(axis=0)
    acceptance = float(acc.mean())
    lp = run.log_prob[burn_in:]
    tz = float(trend_z(lp))
    drifting = bool(abs(tz) > rule.drift_z)
    taus = np.array([table[k]["tau"] for k in names])
    short = [k for k in names if not table[k]["tau_ok"]]
    if short:
        reasons.append(f"the kept chain ({nk} steps) is shorter than {tau_factor:g} IACT for "
                       f"{_list(short)} (max IACT {np.nanmax(taus):.1f} steps): run longer.")
    low_ess = [k for k in names if not table[k]["ess_ok"]]
    if low_ess:
        reasons.append(f"ESS below {ess_min:g} for {_list(low_ess)}.")
    bad_rhat = [k for k in names if not table[k]["rhat_ok"]]
    if bad_rhat:
        reasons.append(f"split-R-hat ≥ {rhat_max} for {_list(bad_rhat)} (walkers disagree).")
    gw = geweke_verdict(kept)  # the stopping rule's own test, on the same rows
    if gw.failed:
        who = f" for {_list(n_fail_gew)}" if n_fail_gew else ""
        reasons.append(f"Geweke: early and late means differ{who}; {gw.text()}.")
    elif n_fail_gew:
        warns.append(f"Geweke |z| ≥ 1.96 for {_list(n_fail_gew)}; for the principal components "
                     f"{gw.n_fail_components} of {gw.zc.size}: no more than chance "
                     f"({0.05 * gw.zc.size:.1f} expected; correlated parameters fail together).")
    if drifting:
        reasons.append(f"the kept log-posterior still drifts (trend z = {tz:.1f}): burn-in is "
                       "not over or the chain is still moving.")
    stuck = int(np.sum(acc_w == 0))
    if stuck:
        reasons.append(f"{stuck} of {m} walkers accepted nothing after burn-in (stuck).")
    if not 0.1 <= acceptance <= 0.9:
        warns.append(f"acceptance {acceptance:.2f} is outside 0.1–0.9: the proposal scale is "
                     "poorly tuned and mixing will be slow.")
    if burn_in > 0.5 * n:
        warns.append(f"burn-in ({burn_in} steps) is more than half the chain.")
    return Assessment(table, acceptance, acc_w, int(burn_in), n, nk, m, drifting, tz,
                      not reasons, reasons, warns, rule, unfinished, int(n_adapt_rows))


def chains_note(sampler: str, rule: StoppingRule | None = None) -> str:
    """What ESS and split-R-hat across chains mean for this sampler (under ``rule``)."""
    n = (rule or StoppingRule()).min_tau_lengths
    if "emcee" in str(sampler):
        return ("emcee walkers are not independent chains (each move uses the other walkers), "
                "so ESS and split-R-hat across walkers are optimistic; the IACT check (chain "
                f">= {n:g} IACT) is the primary one.")
    who = f"the {sampler} sampler's" if sampler else "the sampler's"
    return (f"{who} chains are independent Markov chains, so split-R-hat "
            f"across them compares independent runs; the IACT check (chain >= {n:g} IACT) still "
            "applies to each.")


def _list(names: list[str], k: int = 6) -> str:
    return ", ".join(names[:k]) + (f" and {len(names) - k} more" if len(names) > k else "")
