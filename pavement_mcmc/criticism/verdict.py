"""The ranking's verdict in plain words (see :mod:`.ranking` and :mod:`.entries` for the scores).

Words follow the numbers: the RMSE "falls" only when the refit's is lower than the base
refit's (both MAP fits of the same data); a candidate that helps without explaining is
"partly"; a claim through plausibility says what was impossible.
"""

from __future__ import annotations

from .entries import DATA_THRESHOLD, ENERGY_LAWS, FORECAST_THRESHOLD, LOSO_NONE
from .forecast import ratio_for_gain
from .residuals import ResidualReport, inflation, noise_like

#: share of the excess misfit a claimed candidate removes above which its leftover is "the size
#: of the noise": a "none of these" after it is about the leftover's time structure alone
SIZE_EXPLAINED = 0.95


def _prior_conflicts(entries) -> str:
    """A sentence on the prior-driven candidates ('' if none)."""
    pd = [e for e in entries if e.prior_driven and not e.detected]
    if not pd:
        return ""
    items = ", ".join(
        f"{e.name} (S = {e.score:.0f}, of which {e.delta_prior:.0f} from the priors, with "
        f"{e.added_params:+.1f} effective parameters; data part {e.data_score:.0f} <= "
        f"{e.data_threshold:g})"
        for e in pd
    )
    return (
        f" Not claimed: {items}. Its score does not come from a better fit to the data: the "
        "data alone cannot tell such a candidate from a shift of the other parameters (for "
        "radiation_factor: a common scale of kappa, C and h); it reflects a conflict between the "
        "data and the priors (e.g. on kappa and C), not a detected effect."
    )


def rmse_change(before: float, after: float) -> str:
    """'falls from a to b' / 'rises from a to b' / 'stays at a' (°C), as the numbers say."""
    if after < before - 5e-4:
        return f"falls from {before:.3f} to {after:.3f} °C"
    if after > before + 5e-4:
        return f"rises from {before:.3f} to {after:.3f} °C"
    return f"stays at {before:.3f} °C"


def _where(points, entries) -> str:
    """The sentence naming where the evidence points (the surface energy balance)."""
    by = {e.name: e for e in entries}
    items = []
    for n in points["candidates"]:
        e = by[n]
        v = e.fit.values()
        own = ", ".join(f"{k} = {x:.3g}" for k, x in e.values.items())
        ok = "back in the range of ground materials" if e.restores_plausibility else "still impossible"
        items.append(f"{n} ({own}{'; at the end of its range' if e.at_bound else ''}; kappa "
                     f"{v['kappa']:.3g} W m-1 K-1, C {v['C'] * 1e-6:.3g} MJ m-3 K-1: {ok})")
    return ("Where the model fails: the surface energy balance. The energy the model pushes into "
            "the ground is wrong while conduction below is right (see the energy balance), and the "
            "candidates that act on the surface balance score highest: " + "; ".join(items)
            + ". None is claimed as it stands (its data part or its range does not suffice): the "
            "sink or resistance at the surface is stronger than, or different from, what these "
            "entries allow. ")


def stopped(entries) -> list:
    """The candidates the out-of-sensor check stopped (:attr:`~.entries.Entry.unpredicted`)."""
    return [e for e in entries if e.unpredicted is not None]


def missed_sensors(entries) -> list[str]:
    """The sensors the candidates stopped by the out-of-sensor check miss: every fold beyond
    :data:`~.entries.LOSO_NONE`, not only the worst (in the folds' order)."""
    out: list[str] = []
    for e in stopped(entries):
        folds = e.loso_rmse_sigma or dict([e.unpredicted])
        out += [s for s, r in folds.items() if r > LOSO_NONE and s not in out]
    return out


def sensor_list(labels: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'."""
    return labels[0] if len(labels) == 1 else ", ".join(labels[:-1]) + " and " + labels[-1]


def claimable_by(e) -> str:
    """Why a candidate stopped by the out-of-sensor check would have been claimed, in words."""
    return ("forecasts better" if e.forecasts_better
            else "brings kappa and C back into range")


def forecast_sentence(best, entries, fbase) -> str:
    """The forecast rule's sentence (:mod:`.entries`): how the claimed candidate forecasts the
    held-out period, or that none forecasts it better by the margin ('' without forecasts)."""
    if fbase is None:
        return ""
    period = f"the held-out {fbase.horizon:g} h"
    if best is not None and best.forecast_gain is not None and not best.forecasts_better:
        return (f" It is claimed for the plausibility of its kappa and C, not by its forecast: "
                f"RMSE of {period} {fbase.rmse_sigma:.2f} σ -> {best.forecast_rmse_sigma:.2f} σ, "
                f"F = {best.forecast_gain:.1f} <= {FORECAST_THRESHOLD:g}.")
    if best is not None and best.by_ground and getattr(fbase, "ground", None) is not None:
        return (f" It forecasts the deeper sensors in {period} from the measured top sensor "
                f"better than the base model: RMSE {fbase.ground.rmse_sigma:.2f} σ -> "
                f"{best.ground_rmse_sigma:.2f} σ (ground gain G = {best.ground_gain:.0f} > "
                f"{FORECAST_THRESHOLD:g}; from the forcing alone F = {best.forecast_gain:.0f}).")
    if best is not None and best.forecast_gain is not None:
        return (f" It forecasts {period} from {fbase.driver} better than the base model: "
                f"RMSE {fbase.rmse_sigma:.2f} σ -> {best.forecast_rmse_sigma:.2f} σ (gain F = "
                f"{best.forecast_gain:.0f} > {FORECAST_THRESHOLD:g}).")
    top = max((e for e in entries if e.forecast_gain is not None),
              key=lambda e: e.forecast_gain, default=None)
    if top is None:
        return ""
    vetoed = [e for e in stopped(entries) if e.forecasts_better]
    if vetoed:
        e = max(vetoed, key=lambda x: x.claim_gain)
        return (f" Candidates forecast {period} better by the margin (best {e.name}: RMSE "
                f"{fbase.rmse_sigma:.2f} σ -> {e.forecast_rmse_sigma:.2f} σ, F = "
                f"{e.forecast_gain:.0f}" + (f", G = {e.ground_gain:.0f}" if e.ground_gain is
                                            not None else "")
                + "), but none predicts every sensor from the others.")
    why = ""
    if top.forecast_gain > FORECAST_THRESHOLD:
        why = (", but it leaves too much of the forecast error unexplained" if top.detected else
               ", but it fits worse in sample" if top.score < -top.threshold else
               f", but {', '.join(top.at_bound)} sits at a bound" if top.at_bound else
               ", but its offsets line up with depth" if top.profile else "")
    return (f" No candidate forecasts {period} better by the margin F > {FORECAST_THRESHOLD:g} "
            f"(base forecast RMSE {fbase.rmse_sigma:.2f} σ; best {top.name}: "
            f"{top.forecast_rmse_sigma:.2f} σ, F = {top.forecast_gain:.0f}{why})."
            + _reach(fbase))


def _reach(fbase) -> str:
    """How far the margin is: the RMSE cut it asks of any candidate, from the base forecast's
    effective count of held-out values ('' when the forecast does not carry them)."""
    n, rho = getattr(fbase, "n", None), getattr(fbase, "rho", None)
    if not n or rho is None:
        return ""
    phi, cut = inflation(rho), ratio_for_gain(n, rho, FORECAST_THRESHOLD)
    return (f" The held-out errors are smooth (lag-1 {rho:.2f}: {n / phi:.1f} effective values of "
            f"{n}), so passing the margin asks a forecast RMSE {cut:.2f} times smaller.")


def energy_sentence(entries, base, fbase) -> str:
    """How the surface energy balance (:data:`~.entries.ENERGY`) did, with its figures, when the
    ranking tried it ('' otherwise): named by its forecast or not, and why not."""
    e = next((x for x in entries if x.name in ENERGY_LAWS), None)
    if e is None:
        return ""
    return _energy_forecast(e, base, fbase) + _tower_sentence(e.tower)


def _tower_sentence(tower: dict | None) -> str:
    """The energy balance's implied H and LE against the record's flux tower ('' without)."""
    if not tower:
        return ""
    parts = [f"{k}/Rn {v['implied']:.2f} against "
             + "-".join(f"{x:.2f}" for x in sorted((v["measured"], v["closed"])))
             for k, v in tower["fluxes"].items()]
    return (f" Its midday partition {'agrees with' if tower['agrees'] else 'DISAGREES with'} the "
            f"flux tower's, which the fit did not see ({'; '.join(parts)}, the tower's raw to "
            "its closed share).")


def _energy_forecast(e, base, fbase) -> str:
    txt = (f" The surface energy balance ({e.name}: {', '.join(e.values)} in place of the "
           f"free h(t)) was tried: in sample the MAP RMSE {rmse_change(base.rmse, e.rmse)}")
    if e.forecast_gain is None or fbase is None:
        return txt + "; no forecast (the window is too short to hold a part out)."
    txt += (f"; its forecast of the held-out {fbase.horizon:g} h has RMSE "
            f"{e.forecast_rmse_sigma:.2f} σ against the base model's {fbase.rmse_sigma:.2f} σ, "
            f"F = {e.forecast_gain:.1f}")
    if e.detected:
        return txt + f" > {FORECAST_THRESHOLD:g}: named by forecast."
    why = ([f"F <= {FORECAST_THRESHOLD:g}"] if e.forecast_gain <= FORECAST_THRESHOLD else []) + (
        ["it fits worse in sample"] if e.score < -e.threshold else []) + (
        [f"{', '.join(e.at_bound)} at a bound"] if e.at_bound else [])
    phi = inflation(fbase.rho)
    return txt + (f": not named by forecast ({'; '.join(why)}; the {fbase.n} held-out data, "
                  f"lag-1 {fbase.rho:.2f}, count as {fbase.n / phi:.1f} independent ones).")


def make_verdict(best, entries, lookalikes, rep: ResidualReport, base, none, findings,
                 points=None, fbase=None) -> str:
    """One paragraph: where the evidence points, the missing effect (or none, or "none of
    these") and how it forecasts, the plausibility alarms, then the prior-driven candidates that
    are not claimed."""
    txt = (_where(points, entries) if points else "") + _verdict_main(
        best, entries, lookalikes, rep, base, none) + forecast_sentence(best, entries, fbase)
    txt += energy_sentence(entries, base, fbase)
    alarms = [f for f in findings if f.level == "alarm"]
    if alarms:
        txt += (" The base fit is physically impossible (" + "; ".join(f.text() for f in alarms)
                + "): the model is misspecified whatever the priors.")
    return txt + _prior_conflicts(entries)


def _verdict_main(best, entries, lookalikes, rep, base, none) -> str:
    if best is not None:
        head = "Missing effect" if none is None else "Missing effect (partly)"
        rule = ("forecast gain" if best.forecast_gain is not None and best.forecasts_better
                else "plausibility" if best.plausibility_claim else "score")
        txt = (f"{head}: {best.name} (by its {rule}; in sample: score {best.score:.0f}, data "
               f"part {best.data_score:.0f}, the MAP RMSE {rmse_change(base.rmse, best.rmse)} = "
               f"{best.rmse_sigma:.2f} σ).")
        if best.plausibility_claim:
            v = best.fit.values()
            txt += (f" It brings kappa = {v['kappa']:.3g} W m-1 K-1 and C = {v['C'] * 1e-6:.3g} "
                    "MJ m-3 K-1 back into the range of ground materials without a worse fit.")
        vetoed = stopped(entries)  # named below
        others = [n for n in lookalikes if n != best.name and n not in {e.name for e in vetoed}]
        if others:
            alike = "forecast gain" if best.forecast_gain is not None else "score"
            txt += (f" Look-alikes with a similar {alike}: {', '.join(others)}; "
                    f"{best.name} predicts held-out sensors best.")
        if vetoed:
            txt += (" Not claimed though claimable: " + ", ".join(
                f"{e.name} (it {claimable_by(e)}, but its fit to the other sensors misses the "
                f"{e.unpredicted[0]} sensor by {e.unpredicted[1]:.1f} σ)" for e in vetoed) + ".")
        if best.name == "radiation_factor":
            txt += (
                " Caveat: a radiation factor is identifiable only through the priors on kappa and "
                f"C (scale symmetry with kappa, C and h; {best.delta_prior:.0f} of the score comes "
                "from the priors): it is a radiometer error only if those priors are right."
            )
        if none is not None and none.of == best.name and best.excess_share >= SIZE_EXPLAINED:
            # the size of the misfit is explained, not its time structure: say that, not "partly
            # ... 100 % ... none of these" (measured-top daily windows at 1.0-1.1 sigma)
            txt += (f" It brings the misfit to the size of the noise (RMSE {best.rmse_sigma:.2f} σ) "
                    f"but what is left stays correlated in time (lag-1 {none.rho:.2f}): a small, "
                    "slow error remains that no catalogue entry explains ("
                    + "; ".join(none.why) + f"). Add {best.name}, then diagnose again.")
        elif none is not None:
            txt += (f" It removes {100 * best.excess_share:.0f} % of the excess misfit; something "
                    "else is missing too (add it, then diagnose again). ")
            txt += none.text().splitlines()[0]
        return txt
    if none is not None:
        return none.text().splitlines()[0] + (
            f" Leftover largest at {none.sensor}"
            + (f", following {none.follows[0]} (r = {none.follows[1]:+.2f})" if none.follows else "")
            + "; see the table below for how to write the extension.")
    if noise_like(rep):
        return (
            f"No missing effect detected: RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ is "
            f"within the misfit floor and the residuals show no significant structure "
            + (f"(no candidate forecasts better by the margin F > {FORECAST_THRESHOLD:g})."
               if any(e.forecast_gain is not None for e in entries)
               else f"(no candidate's data part passes {DATA_THRESHOLD:g}).")
        )
    best_data = max((e.data_score for e in entries), default=float("nan"))
    return (
        f"No missing effect claimed: no candidate's data part passes {DATA_THRESHOLD:g} (best "
        f"{best_data:.0f}); RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ, lag-1 {rep.rho:.2f}."
    )


def headline(rk) -> str:
    """The verdict in one or two sentences, for the first line a user reads (the paragraph of
    :func:`make_verdict` gives the reasons): the claimed effect and what credits it, or "none
    of these" and where the evidence points, or no missing effect; then any alarm."""
    best, fb = rk.best, rk.forecast
    if best is not None:
        by = (f"it forecasts the held-out {fb.horizon:g} h "
              + ("of the deeper sensors from the measured top sensor better, G = "
                 f"{best.ground_gain:.0f}" if best.by_ground else f"better, F = {best.forecast_gain:.0f}")
              + f" > {FORECAST_THRESHOLD:g}" if best.forecast_gain is not None and best.forecasts_better
              else "it brings kappa and C back into the range of ground materials"
              if best.plausibility_claim else f"its score {best.score:.0f}")
        txt = f"Verdict: the model misses {best.name} ({by})"
        if rk.none_of_these:
            txt += (", and a small, slow error that no catalogue entry explains remains."
                    if best.excess_share >= SIZE_EXPLAINED else
                    ", and something else that no catalogue entry explains is missing too.")
        else:
            txt += "."
    elif rk.none_of_these:
        vetoed = stopped(rk.entries)
        missed = missed_sensors(vetoed)
        which = ("that forecast better" if all(e.forecasts_better for e in vetoed)
                 else "the rule would claim")
        where = (f" The evidence points at the {rk.points_at['where']}." if rk.points_at else
                 f" The misfit sits in the {missed[0]} sensor: the candidates {which} do not "
                 "predict it from the other sensors." if len(missed) == 1 else
                 f" The candidates {which} do not predict the {sensor_list(missed)} sensors "
                 "from the others." if missed else "")
        txt = f"Verdict: none of the catalogue's effects explains the misfit.{where}"
    else:
        txt = "Verdict: no missing effect detected."
    alarms = [f for f in rk.findings if f.level == "alarm"]
    if alarms:
        txt += (" The base fit is physically impossible ("
                + ", ".join(f.value_text() for f in alarms) + ").")
    return txt
