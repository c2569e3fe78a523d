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
   are scored against the same base fit. The candidate is appended to the model's extensions;
   if that does not reproduce the model at the candidate's null values (a hook that recomputes
   what an earlier one produced, e.g. ``sensor_depth``'s ``observe`` after ``sensor_bias``), it
   is placed first instead, and its description says so.
4. Each candidate is scored against the same base (:mod:`.entries`: the score :math:`S_c`, a BIC
   with autocorrelation-aware counts, and its data part :math:`D_c`). A candidate is claimed
   only if its data part passes :data:`~.entries.DATA_THRESHOLD` on its own (a drop of the
   prior penalty or of the effective parameter count never carries a claim), no own parameter
   sits at a bound, or if it brings a physically impossible base fit back into range without a
   worse misfit. Candidates above the threshold by their score but not by their data part are
   *prior-driven*: reported as a conflict between the data and the priors, never claimed.
5. Claimable candidates whose scores are within ``max(10, 5 %)`` of the best are *look-alikes*; they are
   ordered by a leave-one-sensor-out predictive check (:mod:`.holdout`): a physical effect
   predicts a sensor it was not fitted to, a per-sensor nuisance (offset, depth) cannot.

What it can and cannot distinguish
----------------------------------
- ``radiation_factor`` is exactly confounded with a common scale of kappa, C and h: its data
  part stays near 0 unless the kappa and C priors are tight, so under loose priors it is at most
  prior-driven (measured, 5 % priors 3 % off, factor 0.85 or 1.15, 5 seeds: S <= 15.9, data
  part <= 4.1, never claimed). With tight correct priors (1 %) and h(t) in 1 h pieces a factor
  1.15 ranks first on 5 of 5 seeds (S 65-89, data part 15-37), 0.85 on 3 of 5. With wrong tight
  priors (the paper's literature values) it raises a false alarm: a claimed radiation_factor
  always carries that caveat in the verdict.
- A flexible h(t) (one value per interval, Case C) absorbs wind convection, evaporation and much
  of kappa(T): these are then hard to detect, the more so the smaller gamma. Even h(t) in 1 h
  pieces absorbs kappa(T) at beta = -0.005 /K: the base residuals are those of a clean dataset
  (per-sensor RMSE within 0.01 degC, amplitude within 0.3 %), and its misfit drop (5.6-12.3 on
  3 seeds) overlaps that of clean data (up to 6.6).
- two_layer vs sensor_depth (and kappa(T) vs two_layer) fit some data almost equally; the
  look-alike rule and the hold-out check separate them, the report lists both.
- Effects outside the catalogue are not named: if no candidate is claimed but the residuals are
  structured, or the claimed one leaves the misfit above :data:`~.entries.RMSE_NONE` sigma or
  far from white, the answer is "none of these" (:mod:`.unexplained`: which sensor, which
  forcing the leftover residual follows, and how to write the extension).
"""

from __future__ import annotations

import numpy as np

from ..physics import candidate_names, get_extension
from ..physics.hbasis import FINER_H
from ..physics.materials import check_values, declared_material
from .candidates import finer_h_spec, fit_extension, h_spec_of, h_start, variant
from .entries import (
    DATA_THRESHOLD,
    ENERGY_LAWS,
    FLOOR,
    GROUND_FORECAST,
    LOSO_NONE,
    PER_SENSOR,
    THRESHOLD,
    Entry,
    Ranking,
    at_bounds,
    coherent_profile,
    excess_share,
    score,
)
from .entries import energy_law as law_of
from .fitting import Fit, refit
from .forecast import forecast as forecast_skill
from .forecast import forecast_gain, forecast_share, plugin_gain
from .ground import GROUND_HOOKS, ground_forecast_or_none, ground_gain, where_acts
from .holdout import leave_one_sensor_out
from .holdout import out_of_sensor as sensor_holdout
from .residuals import ResidualReport, analyse_point, noise_like, plain_signals
from .tower import fit_tower
from .unexplained import unexplained
from .verdict import claimable_by, make_verdict, missed_sensors, sensor_list, stopped

__all__ = ["DATA_THRESHOLD", "FINER_H", "THRESHOLD", "Entry", "Ranking", "finer_h_spec",
           "rank_missing_effects"]

#: residual patterns (keys of :func:`~.residuals.plain_signals`) that point at each candidate
SIGNALS = {
    FINER_H: ("corr:T_air-T_s", "corr:tod_sin", "corr:tod_cos", "corr:dT_s/dt"),
}


def _evidence(name: str, ext, patterns: dict[str, str]) -> list[str]:
    keys = SIGNALS.get(name, ()) if ext is None else ext.signals
    out = [patterns[k] for k in keys if k in patterns]
    hint = "h(t) varies faster than its pieces allow" if ext is None else ext.hint
    if hint:
        out.append(f"({hint})")
    return out


def _impossible(fit: Fit, declared) -> list:
    """Alarms on kappa, C or kappa/C of ``fit`` (outside every ground material)."""
    v = fit.values()
    return [f for f in check_values(v.get("kappa"), v.get("C"), None, declared) if f.level == "alarm"]


def _points_at(entries: list[Entry], energy, threshold: float) -> dict | None:
    """The surface energy balance, if :mod:`.energy` says the surface boundary is wrong and the
    highest-scoring candidate acts on the surface (module doc of :mod:`.entries`)."""
    if energy is None or not energy.surface_wrong or not entries:
        return None
    top = max(entries, key=lambda e: e.score)
    surf = sorted((e for e in entries if e.hook == "surface" and e.score > threshold),
                  key=lambda e: -e.score)
    if top.hook != "surface" or not surf:
        return None
    return {"where": "surface energy balance", "candidates": [e.name for e in surf],
            "energy_verdict": energy.verdict}


def energy_candidate(problem, energy, flag: bool | None) -> bool:
    """Whether the ranking tries :data:`ENERGY` (Penman-Monteith's where the record has RH): a
    law for the whole surface balance (H with the wind, LE by Priestley-Taylor or
    Penman-Monteith) in place of the free h(t). Not a catalogue candidate (it nests
    wind_convection and evapotranspiration and would shadow them; the forecast rule's margin was
    calibrated without it), so by default (``flag`` None) only where the energy check
    (:mod:`.energy`) says the surface boundary is wrong -- an impossible kappa or C, a plate
    the model cannot follow: it is the physics that check names. ``flag`` True: whenever the
    model's h(t) is free; False: never. A record without net radiation is skipped with the
    reason (the extension refuses it)."""
    m = problem.model
    if flag is False or m.top_measured or m.replaces_h:
        return False
    return flag is True or (energy is not None and energy.surface_wrong)


def _entry(name, desc, ref: Fit, cand: Fit, ext, patterns, base_impossible, declared) -> Entry:
    s, data, rho = score(ref, cand)
    own = [n for n in cand.names if n not in ref.names] if ext is not None else []
    vals = cand.values()
    return Entry(
        name=name,
        description=desc,
        reference="base",
        score=s,
        data_score=data,
        delta_chi2=ref.chi2 - cand.chi2,
        delta_prior=ref.prior_penalty - cand.prior_penalty,
        added_params=cand.p_eff - ref.p_eff,
        rho=rho,
        rmse=cand.rmse,
        rmse_sigma=cand.rmse_sigma,
        rmse_sensors=np.sqrt(np.mean(cand.residuals**2, axis=0)).tolist(),
        evidence=_evidence(name, ext, patterns),
        values={n: vals[n] for n in own},
        at_bound=at_bounds(cand, own, None if ext is None else ext.null_values(cand.problem.meas)),
        excess_share=excess_share(ref.rmse_sigma, cand.rmse_sigma),
        hook=where_acts(ext),
        profile=name in PER_SENSOR and coherent_profile({n: vals[n] for n in own}),
        restores_plausibility=bool(base_impossible) and not _impossible(cand, declared),
        fit=cand,
    )


def _unpredicted_text(entries: list[Entry]) -> str:
    """Why claimable candidates are not claimed (the out-of-sensor check)."""
    parts = [f"{e.name} ({claimable_by(e)}; the {e.unpredicted[0]} sensor missed by "
             f"{e.unpredicted[1]:.1f} σ)" for e in entries]
    missed = missed_sensors(entries)
    where = (f"the misfit sits in the {missed[0]} sensor: a fault or an effect of that sensor "
             "outside the catalogue (leave it out of [data] observed_cm and diagnose again to "
             "see what the other sensors say)" if len(missed) == 1 else
             f"they miss the {sensor_list(missed)} sensors: the misfit is not one sensor's")
    verb = "does" if len(entries) == 1 else "do"
    return (f"{', '.join(parts)} would be claimed but {verb} not predict that sensor from the "
            f"others (more than {LOSO_NONE:g} σ, not a claim); {where}")


def _none_of_these(best: Entry | None, entries: list[Entry], rep, base: Fit):
    """The :class:`~.unexplained.Unexplained` analysis if no catalogue entry explains the misfit
    (module doc), else None."""
    why = []
    bound = {e.name: e.at_bound for e in entries if e.at_bound and e.data_score > DATA_THRESHOLD}
    coherent = [e.name for e in entries if e.profile and e.data_score > DATA_THRESHOLD]
    unpredicted = stopped(entries)
    if best is not None and not best.explains:
        why.append(f"the best candidate, {best.name}, leaves RMSE {best.rmse_sigma:.2f} σ "
                   f"and lag-1 {best.rho:.2f}")
    elif best is None and unpredicted:
        why.append(_unpredicted_text(unpredicted))
    elif best is None and not noise_like(rep):
        fc = any(e.forecast_gain is not None for e in entries)
        why.append("no candidate forecasts the held-out period better by the margin" if fc
                   else "no candidate's data part passes the threshold")
    if not why:
        return None
    if coherent:
        why.append(f"{', '.join(coherent)} would need offsets of one sign at every sensor, a "
                   "depth profile that independent sensor errors do not make (not a claim)")
    if bound:
        why.append("fitted at a bound (not a claim): " + ", ".join(
            f"{n} ({', '.join(b)})" for n, b in bound.items()))
    if best is not None:  # what the (partial) winner leaves
        return unexplained(analyse_point(best.fit.problem, best.fit.values()), why, best.name, bound)
    return unexplained(analyse_point(base.problem, base.values()), why, "base", bound)


def rank_missing_effects(
    problem,
    values: dict[str, float] | None = None,
    candidates: list[str] | None = None,
    *,
    threshold: float = THRESHOLD,
    holdout: bool = True,
    energy=None,
    report: ResidualReport | None = None,
    forecast: bool | dict = False,
    energy_law: bool | None = None,
) -> Ranking:
    """Rank the catalogue's extensions (and a finer h(t)) by how much they would lower the misfit.

    Parameters
    ----------
    problem : the run's :class:`~pavement_mcmc.posterior.Problem`.
    values : the run's point estimate by parameter name (posterior mean or MAP); default the
        parameters' values. Used for the residual report and as the start of every refit.
    candidates : extension names (or ``"module:Class"``) to try; default every registered
        extension not already in the model whose ``candidate`` is True, plus ``"finer_h"``.
    threshold : score above which a candidate may be claimed (its data part must also pass
        :data:`~.entries.DATA_THRESHOLD`).
    holdout : break ties between look-alikes with a leave-one-sensor-out check.
    energy : the :class:`~.energy.EnergyBalance` of the point estimate, if known: when it says
        the surface boundary is wrong and the surface candidates score highest, the verdict
        names the surface energy balance even if no entry is claimed.
    report : the residual report of ``values`` (:func:`~.residuals.analyse_point`), if known
        (:func:`~.diagnose.diagnose` has it): not computed again.
    forecast : claim by forecast skill (:mod:`.entries`, forecast rule): True, or a dict of
        options of :func:`~.forecast.forecast` (``origins``, ``horizon``, ``rule``) and
        ``ground`` (also the ground forecast of :mod:`.ground` for ground and sensor candidates;
        default :data:`~.entries.GROUND_FORECAST`); False: the in-sample rule alone.
    energy_law : also try the surface energy balance :data:`ENERGY` (:func:`energy_candidate`:
        None where the energy check says the surface boundary is wrong, True always, False
        never); scored and claimed by the same rule as the catalogue.

    Returns
    -------
    Ranking
    """
    values = dict(values or problem.space.value_dict())
    rep = analyse_point(problem, values) if report is None else report
    patterns = plain_signals(rep)
    base = refit(problem, values)
    declared = declared_material(problem)
    findings = check_values(base.values().get("kappa"), base.values().get("C"), None, declared)
    impossible = _impossible(base, declared)
    present = {e.name for e in problem.model.extensions}
    names = [n for n in (candidates or [FINER_H, *candidate_names()]) if n not in present]
    if candidates is None and energy_candidate(problem, energy, energy_law):
        names.append(law_of(problem.meas))  # Penman-Monteith where the record has RH
    entries: list[Entry] = []
    skipped: dict[str, str] = {}
    h_spec = h_spec_of(problem)
    if FINER_H in names:
        spec = finer_h_spec(problem)
        if spec is None:
            skipped[FINER_H] = "h(t) is already one value per interval or given by an extension"
        else:
            fp = variant(problem, list(problem.model.extensions), spec)
            ff = refit(fp, {**base.values(), **h_start(problem, base.values(), fp)})
            desc = (f"h(t) in {len(fp.model.h_basis.names)} pieces "
                    f"instead of {len(problem.model.h_basis.names)}")
            entries.append(_entry(FINER_H, desc, base, ff, None, patterns, impossible, declared))
    for name in names:
        if name == FINER_H:
            continue
        try:
            ext = get_extension(name)
            ext.parameters(problem.meas)
        except ValueError as err:
            skipped[name] = str(err)
            continue
        if problem.model.top_measured and where_acts(ext) == "surface":
            skipped[name] = "acts at the surface, which the measured top boundary replaces"
            continue
        if ext.replaces_h and problem.model.replaces_h:
            skipped[name] = "replaces h(t), which an extension of the model already replaces"
            continue
        if ext.over_soil and any(e.over_soil for e in problem.model.extensions):
            skipped[name] = "a layer over the soil, which the model already has"
            continue
        fit = fit_extension(problem, base, name, h_spec)
        desc = type(ext).__doc__.strip().splitlines()[0] if type(ext).__doc__ else ext.name
        order = [e.name for e in fit.problem.model.extensions]
        if order[-1] != ext.name:
            desc += f" (listed before {', '.join(order[1:])}: after them it would undo them)"
        entries.append(_entry(ext.name, desc, base, fit, ext, patterns, impossible, declared))
    for e in entries:
        e.threshold = threshold
        e.tower = fit_tower(e.fit) if e.name in ENERGY_LAWS else None
    fbase = _forecasts(base, entries, forecast) if forecast is not False else None
    entries = claim_order(entries)
    lookalikes: list[str] = []
    loso: dict[str, np.ndarray] = {}  # each look-alike's leave-one-sensor-out RMSE by sensor
    if entries and entries[0].detected:
        def key(e):
            return e.score if e.forecast_gain is None else e.claim_gain

        top = key(entries[0])
        margin = max(threshold, 0.05 * top)
        close = [e for e in entries if e.detected and key(e) >= top - margin
                 and e.leads == entries[0].leads]
        if len(close) > 1:
            lookalikes = [e.name for e in close]
            if holdout and problem.meas.n_sensors > 1:  # one sensor: nothing to hold out
                for e in close:
                    ho = leave_one_sensor_out(e.fit.problem, e.fit.values())
                    e.loso_lpd, loso[e.name] = ho.lpd, ho.rmse
                close.sort(key=lambda e: -(e.loso_lpd if e.loso_lpd is not None else -np.inf))
                entries = close + [e for e in entries if e not in close]
    if fbase is not None and problem.meas.n_sensors > 1:  # one sensor: no other to refit to
        entries = out_of_sensor(entries, known=loso)
    best = entries[0] if entries and entries[0].detected else None
    none = _none_of_these(best, entries, rep, base)
    if none is not None and best is not None and not (best.plausibility_claim or best.partial):
        best = None  # it helps a little but does not explain: no confident claim
    points = _points_at(entries, energy, threshold) if best is None else None
    verdict = make_verdict(best, entries, lookalikes, rep, base, none, findings, points, fbase)
    return Ranking(entries, base, rep, verdict, best, lookalikes, skipped, threshold, none, findings,
                   points, fbase)


def out_of_sensor(entries: list[Entry], limit: float = LOSO_NONE,
                  known: dict[str, np.ndarray] | None = None) -> list[Entry]:
    """The out-of-sensor check of the forecast rule (:mod:`.entries`): while the first entry
    is claimable, predict each sensor from the others with its model
    (:func:`~.holdout.out_of_sensor`; a per-sensor nuisance's offsets held at its fit); a fold
    worse than ``limit`` sigma marks it :attr:`~.entries.Entry.unpredicted` and the next one is
    checked. ``known``: leave-one-sensor-out RMSEs already computed by name (the look-alikes'),
    the same figures for a candidate that holds nothing and reads its sensors at their
    nominal depths. ``entries`` in claim order; returns
    them in claim order (look-alike order kept)."""
    order = list(entries)
    known = known or {}
    while entries and entries[0].detected:
        e = entries[0]
        fixed = tuple(e.values) if e.name in PER_SENSOR else ()
        same = not fixed and e.name in known and e.fit.problem.model.observes_nominal
        rmse = (known[e.name] if same  # plain leave-one-sensor-out reads the nominal depths
                else sensor_holdout(e.fit.problem, e.fit.values(), fixed))
        sig = float(e.fit.problem.meas.sigma)
        labels = list(e.fit.problem.meas.sensor_labels)
        e.loso_rmse_sigma = {lab: float(r / sig) for lab, r in zip(labels, rmse, strict=True)}
        worst = max(e.loso_rmse_sigma, key=e.loso_rmse_sigma.get)
        if e.loso_rmse_sigma[worst] <= limit:
            break
        e.unpredicted = (worst, e.loso_rmse_sigma[worst])  # behind the claimable ones
        entries = [x for x in order if x.detected] + [x for x in order if not x.detected]
    return entries


def claim_order(entries: list[Entry]) -> list[Entry]:
    """Claimable candidates first, those that :attr:`~.entries.Entry.leads` first among them
    (plausibility claims under the in-sample rule, a better forecast under the forecast rule),
    each group by score (forecast gain under the forecast rule); then the rest by score."""
    return sorted(entries, key=lambda e: (not e.detected, not e.leads,
                                          -(e.score if e.forecast_gain is None else e.claim_gain)))


def _forecasts(base: Fit, entries: list[Entry], options: bool | dict):
    """The base model's forecast, and each candidate's with its gain and share (forecast rule of
    :mod:`.entries`); None (in-sample rule) when the window is too short to hold a part out."""
    opts = {} if options is True else dict(options)
    ground = opts.pop("ground", GROUND_FORECAST)
    try:
        fb = forecast_skill(base.problem, base.values(), **opts)
    except ValueError:
        return None
    for e in entries:
        fc = forecast_skill(e.fit.problem, e.fit.values(), **opts)
        e.forecast = fc
        e.forecast_gain = forecast_gain(fb, fc)
        e.plugin_gain = plugin_gain(fb, fc)
        e.forecast_share = forecast_share(fb, fc, FLOOR)
        e.forecast_rmse_sigma = fc.rmse_sigma
    if ground:
        _ground_gains(base, fb, entries)
    return fb


def _ground_gains(base: Fit, fb, entries: list[Entry]) -> None:
    """The ground forecast (:mod:`.ground`) of the base model into ``fb.ground`` and each
    ground or sensor candidate's gain over it (none where the case has one sensor or a
    measured top)."""
    fb.ground = ground_forecast_or_none(base.problem, fb)
    if fb.ground is None:
        return
    for e in entries:
        if e.hook in GROUND_HOOKS:
            gc = ground_forecast_or_none(e.fit.problem, e.forecast)
            if gc is None:  # its fit moved the top sensor to or below the next
                continue
            e.ground_gain = ground_gain(fb.ground, gc)
            e.ground_rmse_sigma = gc.rmse_sigma
