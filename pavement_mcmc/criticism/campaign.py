"""Validation campaigns of the criticism on twins: plain functions of a list of twins.

Each twin (:mod:`pavement_mcmc.synthetic.corpus`) is simulated by the independent simulator and
diagnosed from its case's MAP fit; :func:`diagnose_twins` returns one record per twin and
:func:`rates` reduces them to the numbers ``make validate`` prints:

- the false-alarm rate on clean twins: a catalogue effect claimed where none is hidden (a finer
  h(t) on a coarse-h case is not a false alarm: the discretisation is itself misspecified);
- per catalogue effect, how often it is ranked first (claimed) and its refit RMSE over the RMSE
  of the true model at the true parameters;
- the "none of these" rate on off-catalogue twins, and how often a catalogue entry is claimed
  there with confidence (a partial claim counts as confident);
- with ``forecast`` on (the forecast rule of :mod:`.entries`): each twin's forecast gains and,
  on clean twins, the base model's forecast RMSE over that of the true parameters under the
  same future rule (:func:`truth_forecast_rmse`: the score measures the model, not the rule).

A later batch engine may map :func:`diagnose_twin` over the twins in parallel.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..data import load_case
from ..physics.hbasis import FINER_H
from ..posterior import build_problem
from ..synthetic.corpus import forecast_twins, write_twin
from .calibration import found, row_key
from .fitting import refit
from .forecast import (
    default_origins,
    future_values,
    gain,
    held_out,
    split_rows,
    training_problem,
)
from .ground import GROUND_HOOKS, ground_forecast_or_none, ground_gain
from .ranking import rank_missing_effects


def _true_values(cfg, effects: list[str]):
    """The true model's problem (true h per interval) and its true parameter values."""
    truth = json.loads(Path(cfg.truth_path).read_text())
    smooth = "gamma" in cfg.parameters  # a case with a smoothness prior names its gamma
    # input noise linearised at the parameters' values (no MAP fit): only predictions are used
    pb = build_problem(cfg, extensions=list(effects),
                       h_spec={"kind": "per_interval", "smooth": smooth}, input_noise={})
    vals = {k: float(v[0]) for k, v in pb.space.values().items()}
    vals.update(kappa=truth["kappa"], C=truth["C"])
    h = np.asarray(truth["h_true_obs"])
    if not pb.model.replaces_h:
        vals.update(zip(pb.model.h_basis.names, 0.5 * (h[1:] + h[:-1]), strict=True))
    for e in effects:
        vals.update({k: v for k, v in truth["effects"][e].items() if k in vals})
    return pb, vals


def true_rmse(cfg, effects: list[str]) -> float:
    """RMSE of the true model at the true parameters (true h per interval) on the twin's data."""
    pb, vals = _true_values(cfg, effects)
    p = {k: np.array([v]) for k, v in vals.items()}
    r = pb.model.predict(p)[0, 1:] - pb.meas.T_obs[1:]
    return float(np.sqrt(np.mean(r**2)))


def truth_forecast_rmse(cfg, effects: list[str], rule: str = "diurnal") -> float:
    """Forecast RMSE with the true parameters over the fitted part and the future rule after it
    (:mod:`.forecast`), true model, default origin: what a perfect fit would forecast."""
    pb, vals = _true_values(cfg, effects)
    (origin,), _ = default_origins(pb.meas.t)
    n_train = split_rows(pb.meas.t, origin)
    train = training_problem(pb, n_train)
    known = {k: v for k, v in vals.items() if k in train.space}
    r, _, _ = held_out(pb, future_values(pb, train, known, rule), n_train, pb.meas.n_obs - 1)
    return float(np.sqrt(np.mean(r**2)))


#: the truth-parameter model stands for the twin's truth when its in-sample RMSE is within this
#: factor of the base fit's: a form the inversion does not share shows as a misfit (the
#: evapotranspiration twins' available energy R_n - G against the catalogue's R_n: 3.3-4.1
#: sigma at the true coefficient, against 1.1-1.5 sigma for the effects whose form it shares)
ORACLE_FORM_FACTOR = 2.0


def oracle(cfg, effect: str, base_forecast: dict, base_rmse_sigma: float,
           rule: str = "diurnal") -> dict:
    """The forecast gain the truth itself would score against the base fit: the true model
    (``effect`` in the catalogue's form, every parameter at its true value, the true h(t) over
    the training part and ``rule`` after it) forecasting the held-out part, scored like a
    candidate (:func:`~.forecast.forecast_gain`) against the base fit's forecast
    (``base_forecast``: its ``rmse_sigma``, ``rho`` and ``n``). A reference, not a bound: it
    holds its seed's clean null (the true h(t) against a fitted one: F 33.7 on the clean twin
    of seed 3702, ``benchmarks/oracle_seed_null.py``), a fitted candidate may forecast better
    than the truth (26 of the 70 valid oracles of ``docs/campaign/forecast_oos_s3000``, past
    the margin where the truth is not on 2), and the ground gain, which claims too, is not
    scored here.

    Returns ``{"F": ..., "truth_fc_rmse_sigma": ..., "truth_rmse_sigma": ..., "valid": bool,
    "why": str}``; ``valid`` is False (and ``F`` None) when the twin records no true value of one
    of the candidate's parameters (it may record a derived one: the layer of ``surface_layer``
    gives its ``R_surface``) or the truth-parameter model misfits the twin
    (:data:`ORACLE_FORM_FACTOR`)."""
    sigma = float(cfg.measurements.sigma)
    truth = json.loads(Path(cfg.truth_path).read_text())
    pb, _ = _true_values(cfg, [effect])
    (origin,), _ = default_origins(pb.meas.t)
    n = (pb.meas.n_obs - 1 - split_rows(pb.meas.t, origin)) * pb.meas.n_sensors
    if base_forecast["n"] != n:  # e.g. a twin simulated again at other hours than the record's
        raise ValueError(f"the base forecast holds {base_forecast['n']} held-out data, this "
                         f"twin's forecast {n}: not the twin the base forecast was made on")
    ext = next(e for e in pb.model.extensions if e.name == effect)
    unknown = sorted(q.name for q in ext.parameters(pb.meas)
                     if q.name not in truth["effects"][effect])
    out = {"F": None, "truth_fc_rmse_sigma": None, "truth_rmse_sigma": None, "valid": False}
    if unknown:
        return {**out, "why": f"the twin records no true value of the catalogue's "
                              f"{', '.join(unknown)}"}
    fit_sigma = true_rmse(cfg, [effect]) / sigma
    out["truth_rmse_sigma"] = round(fit_sigma, 4)
    if fit_sigma > ORACLE_FORM_FACTOR * base_rmse_sigma:
        return {**out, "why": f"the catalogue's {effect} at the true parameters misfits the twin "
                              f"({fit_sigma:.2f} sigma against the base fit's "
                              f"{base_rmse_sigma:.2f}): the simulator's form differs"}
    fc = truth_forecast_rmse(cfg, [effect], rule) / sigma
    f = gain(base_forecast["n"], base_forecast["rho"], base_forecast["rmse_sigma"], fc)
    return {"F": round(f, 3), "truth_fc_rmse_sigma": round(fc, 4),
            "truth_rmse_sigma": round(fit_sigma, 4), "valid": True, "why": ""}


def _entry_record(e) -> dict:
    """What the claim rule reads of one candidate (re-applying a rule to stored records)."""
    return {"F": round(e.forecast_gain, 3), "plugin_F": round(e.plugin_gain, 3),
            "S": round(e.score, 2), "D": round(e.data_score, 2),
            "fc_rmse_sigma": round(e.forecast_rmse_sigma, 4), "share": round(e.forecast_share, 4),
            "excess_share": round(e.excess_share, 4), "rmse_sigma": round(e.rmse_sigma, 4),
            "rho": round(e.rho, 3), "at_bound": list(e.at_bound), "profile": e.profile,
            "detected": e.detected, "explains": e.explains, "partial": e.partial,
            "plausibility": e.plausibility_claim,
            **({} if e.loso_lpd is None else {"loso_lpd": round(e.loso_lpd, 4)}),
            **({} if e.loso_rmse_sigma is None else
               {"loso_rmse_sigma": {k: round(v, 3) for k, v in e.loso_rmse_sigma.items()}}),
            **({} if e.unpredicted is None else {"unpredicted": list(e.unpredicted)})}


def diagnose_twin(twin, directory: str | Path, *, forecast: bool = False,
                  candidates: list[str] | None = None) -> dict:
    """Simulate ``twin`` into ``directory``, fit its case by MAP, rank the candidates (by the
    forecast rule with ``forecast``); one record."""
    t0 = time.perf_counter()
    cfg = load_case(write_twin(twin, Path(directory) / twin.name))
    problem = build_problem(cfg)
    base = refit(problem)
    # the rule as `diagnose` applies it: look-alikes ordered by leave-one-sensor-out (it costs
    # refits only when two claimable candidates score alike)
    rk = rank_missing_effects(problem, base.values(), candidates, holdout=True, forecast=forecast)
    rec = {
        "twin": twin.name,
        "category": twin.category,
        "hidden": list(twin.hidden),
        "claimed": None if rk.best is None else rk.best.name,
        "partial": bool(rk.best is not None and rk.best.partial),
        "none_of_these": rk.none_of_these,
        "first": rk.entries[0].name if rk.entries else None,
        "lookalikes": rk.lookalikes,
        "base_rmse_sigma": base.rmse_sigma,
        "verdict": rk.verdict,
    }
    if len(twin.hidden) == 1:
        e = next((x for x in rk.entries if x.name == twin.hidden[0]), None)
        if e is not None:
            try:
                ideal = true_rmse(cfg, list(twin.hidden))
            except (KeyError, ValueError, OSError):
                ideal = float("nan")
            rec.update(refit_rmse=e.rmse, true_rmse=ideal, rmse_ratio=e.rmse / ideal,
                       data_score=e.data_score)
    if rk.forecast is not None:
        rec.update(forecast_rmse_sigma=rk.forecast.rmse_sigma, forecast_rho=rk.forecast.rho,
                   forecast_n=rk.forecast.n,
                   gains={e.name: round(e.forecast_gain, 2) for e in rk.entries},
                   forecast_shares={e.name: round(e.forecast_share, 3) for e in rk.entries},
                   entries={e.name: _entry_record(e) for e in rk.entries})
        _ground_records(problem, rk, rec)
        if not twin.hidden:
            ideal = truth_forecast_rmse(cfg, [], rk.forecast.rule)
            rec.update(truth_forecast_rmse=ideal, forecast_ratio=rk.forecast.rmse / ideal)
        elif len(twin.hidden) == 1 and twin.category == "catalogue":
            fc = {"rmse_sigma": rk.forecast.rmse_sigma, "rho": rk.forecast.rho,
                  "n": rk.forecast.n}
            rec["oracle"] = oracle(cfg, twin.hidden[0], fc, base.rmse_sigma, rk.forecast.rule)
    rec["seconds"] = time.perf_counter() - t0
    return rec


def _ground_records(problem, rk, rec: dict) -> None:
    """The ground forecast (:mod:`.ground`) of the base and of every candidate into ``rec``:
    its gain ``G``, RMSE in sigma and whether it may credit the candidate (``ground``)."""
    gb = ground_forecast_or_none(problem, rk.forecast)
    if gb is None:  # one sensor, or a measured top: no ground forecast
        return
    rec["ground_rmse_sigma"] = gb.rmse_sigma
    rec["ground_rho"] = gb.rho
    for e in rk.entries:
        if e.forecast is None or e.fit is None:
            continue
        gc = ground_forecast_or_none(e.fit.problem, e.forecast)
        if gc is None:  # its fit moved the top sensor to or below the next
            continue
        rec["entries"][e.name].update(G=round(ground_gain(gb, gc), 3),
                                      g_rmse_sigma=round(gc.rmse_sigma, 4),
                                      ground=e.hook in GROUND_HOOKS)


def diagnose_twins(twins, directory: str | Path, *, forecast: bool = False) -> list[dict]:
    """:func:`diagnose_twin` of every twin, in order."""
    return [diagnose_twin(t, directory, forecast=forecast) for t in twins]


#: the catalogue effects and the off-catalogue ones of the forecast rule's campaign
FORECAST_CATALOGUE = ("wind_convection", "evaporation", "evapotranspiration", "radiation_factor",
                      "conductivity_temperature", "two_layer", "sensor_bias", "sensor_depth",
                      "surface_layer")
FORECAST_OFF = ("sensor_sun", "sensor_lag", "shading", "buried_source")


def forecast_campaign_twins(n_clean: int = 40, n_effect: int = 10, n_off: int = 3, *,
                            hours: float = 40.0, input_sigma: bool = True,
                            seed_offset: int = 0, effects=FORECAST_CATALOGUE,
                            params: dict[str, dict] | None = None,
                            spec: dict | None = None) -> list:
    """The forecast rule's calibration twins (:func:`~pavement_mcmc.synthetic.corpus.forecast_twins`):
    ``n_clean`` clean, ``n_effect`` of each :data:`FORECAST_CATALOGUE` effect, ``n_off`` of each
    :data:`FORECAST_OFF` effect, interleaved in proportion: the i-th of a category's n twins
    (in rounds of one seed of every effect) comes at (i + 1/2) / n of the run, so a run cut short
    holds the same share of every category and of every effect. ``seed_offset`` shifts every
    seed (1000: a fresh campaign to replicate rates measured on the default seeds); ``effects``
    a subset of the catalogue effects; ``params`` an effect's parameters other than its
    defaults and ``spec`` other simulator settings
    (:func:`~pavement_mcmc.synthetic.corpus.forecast_twins`)."""
    stray = sorted(set(params or {}) - set(effects))
    if stray:
        raise ValueError(f"parameters given for {', '.join(stray)}, not among the hidden effects "
                         f"({', '.join(effects)})")
    kw = {"hours": hours, "input_sigma": input_sigma, "params": params, "spec": spec}
    s0 = seed_offset
    groups = [
        [t for k in range(n_clean) for t in forecast_twins((), (s0 + 600 + k,), **kw)],
        [t for k in range(n_effect) for t in forecast_twins(tuple(effects), (s0 + 700 + k,), **kw)],
        [t for k in range(n_off) for t in forecast_twins(FORECAST_OFF, (s0 + 800 + k,), **kw)],
    ]
    keyed = [((i + 0.5) / len(g), j, t) for j, g in enumerate(groups) for i, t in enumerate(g)]
    return [t for *_, t in sorted(keyed, key=lambda x: x[:2])]


def ceiling(records: list[dict], margin: float) -> dict:
    """Per catalogue effect, what the truth itself would score (:func:`oracle`, the records'
    ``oracle``; twins of other strengths or simulator settings under their own key, the effect
    and their names' tag, e.g. ``conductivity_temperature-kappa_beta-0.015``): ``n`` twins,
    ``valid`` oracles among them, ``passes`` (the truth's F above ``margin``: where the
    forecast gain is expected to claim; :func:`oracle` says why this is no bound) and
    ``claimed`` among those that pass and among all. Under ``"clean"`` the same figure on
    clean twins, where the true model is the base model and its truth-parameter forecast beats
    the fitted one by chance alone: the null distribution of the truth's F."""
    out = {}
    null = [gain(r["forecast_n"], r["forecast_rho"], r["forecast_ratio"], 1.0)
            for r in records if r["category"] == "clean" and "forecast_ratio" in r]
    if null:
        out["clean"] = {"n": len(null), "valid": len(null), "F": [round(f, 3) for f in null],
                        "passes": sum(f > margin for f in null), "claimed_where_passes": 0,
                        "claimed": 0, "why": ""}
    for r in records:
        if r["category"] != "catalogue" or "oracle" not in r:
            continue
        eff, o = r["hidden"][0], r["oracle"]
        # twins at other strengths or settings (their names' tags) are rows of their own
        key = row_key(r)
        c = out.setdefault(key, {"n": 0, "valid": 0, "passes": 0, "claimed_where_passes": 0,
                                 "claimed": 0, "F": [], "why": ""})
        c["n"] += 1
        c["claimed"] += r["claimed"] == eff
        if not o["valid"]:
            c["why"] = o["why"]
            continue
        c["valid"] += 1
        c["F"].append(o["F"])
        if o["F"] > margin:
            c["passes"] += 1
            c["claimed_where_passes"] += r["claimed"] == eff
    return out


def rates(records: list[dict]) -> dict:
    """The campaign's rates (module doc) from :func:`diagnose_twins` records."""
    clean = [r for r in records if r["category"] == "clean"]
    cat = [r for r in records if r["category"] == "catalogue"]
    off = [r for r in records if r["category"] == "off_catalogue"]
    false = [r for r in clean if r["claimed"] not in (None, FINER_H)]
    per_effect = {}
    for key in sorted({row_key(r) for r in cat}):
        rs = [r for r in cat if row_key(r) == key]
        per_effect[key] = {
            "first": sum(found(r["claimed"], r["hidden"][0]) for r in rs),
            "n": len(rs),
            "rmse_ratio": [round(r.get("rmse_ratio", float("nan")), 3) for r in rs],
        }
    confident = [r for r in off if r["claimed"] not in (None, FINER_H)]
    return {
        "false_alarm": (len(false), len(clean)),
        "false_alarm_twins": [(r["twin"], r["claimed"]) for r in false],
        "true_first": per_effect,
        "none_of_these": (sum(r["none_of_these"] and r["claimed"] is None for r in off), len(off)),
        "off_confident_claims": [(r["twin"], r["claimed"]) for r in confident],
        "forecast_ratio": [round(r["forecast_ratio"], 3) for r in clean if "forecast_ratio" in r],
    }
