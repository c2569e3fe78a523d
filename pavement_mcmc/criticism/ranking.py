r"""Which effect is missing: rank candidate model extensions by penalised misfit drop.

Method
------
1. Refit the run's model by MAP from its point estimate (the *base* fit).
2. **Finer h(t)** is a candidate like the others (unless h is already one value per interval
   or an extension replaces it): every piece longer than 2 h is cut into pieces of at most 2 h,
   other pieces are halved. A coarse h(t) is itself a missing effect (Cases A/B), and a
   candidate must beat it to be believed: an effect that only soaks up the h(t) misfit scores
   below finer_h.
3. Each catalogue extension not yet in the model is added to the base model and the model is
   refitted by MAP, starting from the base fit and the extension's null values (a few starts
   for extensions with several optima, see ``start_values`` in the catalogue). All candidates
   are scored against the same base fit.
4. Score of candidate ``c`` against the base ``r`` (a BIC with autocorrelation-aware counts):

   .. math::
       S_c = \frac{\chi^2_r - \chi^2_c}{\phi_c} + (P_r - P_c)
             - (p^\mathrm{eff}_c - p^\mathrm{eff}_r)\,\log n^\mathrm{eff}_c,\qquad
       \phi_c = \frac{1+\rho_c}{1-\rho_c},\quad n^\mathrm{eff}_c = n/\phi_c

   :math:`\chi^2` the standardised data misfit, :math:`P` the prior penalty (:math:`-2\log`
   prior), :math:`\rho_c` the pooled lag-1 autocorrelation of the candidate's residuals (so a
   candidate that leaves correlated residuals gets its misfit drop discounted as if the data
   were :math:`n^\mathrm{eff}` independent values), :math:`p^\mathrm{eff}` the effective number of
   data-determined parameters (:mod:`.fitting`; ``rad_factor``, pinned only through the priors
   on kappa and C, counts what the data decide, not 1). A candidate is *detected* if
   :math:`S_c > 10` (on the :math:`2\ln` Bayes-factor scale "very strong").
5. Candidates whose scores are within ``max(10, 5 %)`` of the best are *look-alikes*; they are
   ordered by a leave-one-sensor-out predictive check (:mod:`.holdout`): a physical effect
   predicts a sensor it was not fitted to, a per-sensor nuisance (offset, depth) cannot.

What it can and cannot distinguish
----------------------------------
- ``radiation_factor`` is exactly confounded with a common scale of kappa, C and h: it is
  detected only as a conflict between the data and the priors on kappa / C (the score's prior
  part). With wrong tight priors (the paper's literature values) it raises a false alarm; the
  ranking prints the data and prior parts of the improvement separately.
- A flexible h(t) (one value per interval, Case C) absorbs wind convection, evaporation and much
  of kappa(T): these are then hard to detect, the more so the smaller gamma.
- two_layer vs sensor_depth (and kappa(T) vs two_layer) fit some data almost equally; the
  look-alike rule and the hold-out check separate them, the report lists both.
- Effects outside the catalogue are not named: if no candidate is detected but the residuals
  are structured, the strongest residual correlations are reported instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..physics import extension_names, get_extension
from ..problem import build_problem
from .fitting import Fit, refit
from .holdout import leave_one_sensor_out
from .residuals import ResidualReport, analyse_point, noise_like, plain_signals, pooled_lag1

THRESHOLD = 10.0
FINER_H = "finer_h"

#: residual patterns (keys of :func:`~.residuals.plain_signals`) that point at each candidate
SIGNALS = {
    FINER_H: ("corr:T_air-T_s", "corr:tod_sin", "corr:tod_cos", "corr:dT_s/dt"),
}


@dataclass
class Entry:
    """One ranked candidate.

    Attributes
    ----------
    name : extension name or ``"finer_h"``.
    description : what the candidate adds, in words.
    reference : the model it was compared with (``"base"``).
    score : penalised evidence :math:`S_c` (see module doc); > 10 means detected.
    delta_chi2 : raw misfit drop :math:`\\chi^2_r - \\chi^2_c`.
    delta_prior : prior-penalty drop :math:`P_r - P_c`.
    added_params : :math:`p^{eff}_c - p^{eff}_r`.
    rho : pooled lag-1 autocorrelation of the candidate's residuals.
    rmse : overall RMSE of the candidate fit, degC; ``rmse_sigma`` in sigma.
    rmse_sensors : per-sensor RMSE, degC.
    evidence : plain-words residual patterns that support the candidate, plus its hint.
    values : the candidate's own fitted parameters.
    loso_lpd : leave-one-sensor-out log predictive density per datum (look-alikes only).
    fit : the refit (not serialised).
    """

    name: str
    description: str
    reference: str
    score: float
    delta_chi2: float
    delta_prior: float
    added_params: float
    rho: float
    rmse: float
    rmse_sigma: float
    rmse_sensors: list[float]
    evidence: list[str]
    values: dict[str, float]
    loso_lpd: float | None = None
    fit: Fit | None = field(default=None, repr=False)

    @property
    def detected(self) -> bool:
        return self.score > THRESHOLD

    def to_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k != "fit"}
        d["detected"] = self.detected
        return d


@dataclass
class Ranking:
    """The ranked candidates and the verdict.

    Attributes
    ----------
    entries : candidates, best first.
    base : the MAP refit of the run's model.
    residuals : residual report of the base point estimate.
    verdict : one paragraph in plain words.
    best : the detected missing effect (first entry) or None.
    lookalikes : names of candidates indistinguishable from the best by the score.
    skipped : candidate -> why it could not be tried.
    """

    entries: list[Entry]
    base: Fit
    residuals: ResidualReport
    verdict: str
    best: Entry | None
    lookalikes: list[str]
    skipped: dict[str, str]

    def to_dict(self) -> dict:
        return {
            "verdict": self.verdict,
            "missing_effect": None if self.best is None else self.best.name,
            "lookalikes": self.lookalikes,
            "base": {
                "chi2": self.base.chi2,
                "rmse": self.base.rmse,
                "p_eff": self.base.p_eff,
                "prior_penalty": self.base.prior_penalty,
            },
            "threshold": THRESHOLD,
            "candidates": [e.to_dict() for e in self.entries],
            "skipped": self.skipped,
        }


def finer_h_spec(problem) -> dict | None:
    """A finer h(t) than the problem's (pieces <= 2 h, at least halved); None if h is already
    per interval or replaced by an extension."""
    model = problem.model
    if model.replaces_h:
        return None
    b = model.h_basis
    if len(b.names) >= problem.meas.n_obs - 1:
        return None
    e = b.edges / 3600.0
    new = []
    for a, c in zip(e[:-1], e[1:], strict=True):
        k = max(2, math.ceil((c - a) / 2.0 - 1e-9))
        new.extend(np.linspace(a, c, k + 1)[:-1].tolist())
    new.append(float(e[-1]))
    return {"kind": "pieces", "edges_hours": new, "smooth": bool(b.smooth)}


def _h_spec(problem) -> dict:
    b = problem.model.h_basis
    return {"kind": "pieces", "edges_hours": (b.edges / 3600.0).tolist(), "smooth": bool(b.smooth)}


def _h_start(problem_from, values: dict[str, float], problem_to) -> dict[str, float]:
    """Start values of ``problem_to``'s h pieces from the pieces of ``problem_from``."""
    bf, bt = problem_from.model.h_basis, problem_to.model.h_basis
    out = {}
    if problem_from.model.replaces_h or problem_to.model.replaces_h:
        return out
    mid = 0.5 * (bt.edges[1:] + bt.edges[:-1])
    j = np.clip(np.searchsorted(bf.edges, mid) - 1, 0, len(bf.names) - 1)
    for name, jj in zip(bt.names, j, strict=True):
        if bf.names[jj] in values:
            out[name] = values[bf.names[jj]]
    return out


def _score(ref: Fit, cand: Fit) -> tuple[float, float]:
    rho = pooled_lag1(cand.residuals)
    phi = (1 + rho) / (1 - rho)
    n_eff = cand.residuals.size / phi
    s = (
        (ref.chi2 - cand.chi2) / phi
        + (ref.prior_penalty - cand.prior_penalty)
        - (cand.p_eff - ref.p_eff) * math.log(n_eff)
    )
    return float(s), float(rho)


def _evidence(name: str, ext, patterns: dict[str, str]) -> list[str]:
    keys = SIGNALS.get(name, ()) if ext is None else ext.signals
    out = [patterns[k] for k in keys if k in patterns]
    hint = "h(t) varies faster than its pieces allow" if ext is None else ext.hint
    if hint:
        out.append(f"({hint})")
    return out


def _entry(name, desc, ref_name, ref: Fit, cand: Fit, ext, patterns) -> Entry:
    s, rho = _score(ref, cand)
    own = [n for n in cand.names if n not in ref.names] if ext is not None else []
    vals = cand.values()
    sig = cand.problem.meas.sigma
    return Entry(
        name=name,
        description=desc,
        reference=ref_name,
        score=s,
        delta_chi2=ref.chi2 - cand.chi2,
        delta_prior=ref.prior_penalty - cand.prior_penalty,
        added_params=cand.p_eff - ref.p_eff,
        rho=rho,
        rmse=cand.rmse,
        rmse_sigma=cand.rmse / sig,
        rmse_sensors=np.sqrt(np.mean(cand.residuals**2, axis=0)).tolist(),
        evidence=_evidence(name, ext, patterns),
        values={n: vals[n] for n in own},
        fit=cand,
    )


def _fit_extension(ref_problem, ref_fit: Fit, name: str, h_spec: dict) -> Fit:
    exts = list(ref_problem.model.extensions) + [name]
    prob = build_problem(ref_problem.cfg, extensions=exts, h_spec=h_spec)
    ext = prob.model.extensions[-1]
    base_vals = ref_fit.values()
    start = dict(base_vals)
    null = ext.null_values(prob.meas) or {}
    start.update(null)
    starts = [start]
    starts = [{**start, **s} for s in ext.start_values(prob.meas, base_vals)] or starts
    fits = [refit(prob, s) for s in starts]
    return min(fits, key=lambda f: f.objective)


def rank_missing_effects(
    problem,
    values: dict[str, float] | None = None,
    candidates: list[str] | None = None,
    *,
    threshold: float = THRESHOLD,
    holdout: bool = True,
) -> Ranking:
    """Rank the catalogue's extensions (and a finer h(t)) by how much they would lower the misfit.

    Parameters
    ----------
    problem : the run's :class:`~pavement_mcmc.problem.Problem`.
    values : the run's point estimate by parameter name (posterior mean or MAP); default the
        parameters' values. Used for the residual report and as the start of every refit.
    candidates : extension names (or ``"module:Class"``) to try; default every registered
        extension not already in the model, plus ``"finer_h"``.
    threshold : score above which a candidate is reported as detected.
    holdout : break ties between look-alikes with a leave-one-sensor-out check.

    Returns
    -------
    Ranking
    """
    values = dict(values or {k: float(v[0]) for k, v in problem.space.values().items()})
    rep = analyse_point(problem, values)
    patterns = plain_signals(rep)
    base = refit(problem, values)
    present = {e.name for e in problem.model.extensions}
    names = [n for n in (candidates or [FINER_H, *extension_names()]) if n not in present]
    entries: list[Entry] = []
    skipped: dict[str, str] = {}
    h_spec = _h_spec(problem)
    if FINER_H in names:
        spec = finer_h_spec(problem)
        if spec is None:
            skipped[FINER_H] = "h(t) is already one value per interval or given by an extension"
        else:
            fp = build_problem(problem.cfg, extensions=list(problem.model.extensions), h_spec=spec)
            start = {**base.values(), **_h_start(problem, base.values(), fp)}
            ff = refit(fp, start)
            entries.append(
                _entry(
                    FINER_H,
                    f"h(t) in {len(fp.model.h_basis.names)} pieces "
                    f"instead of {len(problem.model.h_basis.names)}",
                    "base",
                    base,
                    ff,
                    None,
                    patterns,
                )
            )
    for name in names:
        if name == FINER_H:
            continue
        try:
            ext = get_extension(name)
            ext.parameters(problem.meas)
        except ValueError as err:
            skipped[name] = str(err)
            continue
        fit = _fit_extension(problem, base, name, h_spec)
        desc = type(ext).__doc__.strip().splitlines()[0] if type(ext).__doc__ else ext.name
        entries.append(_entry(ext.name, desc, "base", base, fit, ext, patterns))
    entries.sort(key=lambda e: -e.score)
    lookalikes: list[str] = []
    if entries and entries[0].score > threshold:
        top = entries[0].score
        margin = max(threshold, 0.05 * top)
        close = [e for e in entries if e.score >= top - margin]
        if len(close) > 1:
            lookalikes = [e.name for e in close]
            if holdout:
                for e in close:
                    e.loso_lpd = leave_one_sensor_out(e.fit.problem, e.fit.values()).lpd
                close.sort(key=lambda e: -(e.loso_lpd if e.loso_lpd is not None else -np.inf))
                entries = close + [e for e in entries if e not in close]
    best = entries[0] if entries and entries[0].score > threshold else None
    verdict = _verdict(best, entries, lookalikes, rep, threshold)
    return Ranking(entries, base, rep, verdict, best, lookalikes, skipped)


def _verdict(best, entries, lookalikes, rep: ResidualReport, threshold) -> str:
    if best is not None:
        txt = (
            f"Missing effect: {best.name} (score {best.score:.0f}; RMSE would fall from "
            f"{rep.rmse:.3f} to {best.rmse:.3f} °C = {best.rmse_sigma:.2f} σ)."
        )
        others = [n for n in lookalikes if n != best.name]
        if others:
            txt += (
                f" Look-alikes with a similar in-sample score: {', '.join(others)}; "
                f"{best.name} predicts held-out sensors best."
            )
        if best.name == "radiation_factor" and best.delta_prior > 0.5 * best.score:
            txt += (
                " Most of the evidence comes from the priors on kappa/C: a radiation factor "
                "is indistinguishable from wrong priors on kappa and C."
            )
        return txt
    if noise_like(rep):
        return (
            f"No missing effect detected: RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ is "
            f"within the misfit floor and the residuals show no significant structure "
            f"(no candidate scores above {threshold:g})."
        )
    corr = rep.strongest_correlations(z_min=3.0, k=3)
    words = "; ".join(f"{lab} with {name} (r = {r:+.2f})" for lab, name, r, _ in corr) or "none"
    return (
        f"The residuals are structured (RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ, "
        f"lag-1 {rep.rho:.2f}) but no catalogue entry explains them (best score "
        f"{entries[0].score:.0f} <= {threshold:g} if any). Strongest correlations: {words}."
    )
