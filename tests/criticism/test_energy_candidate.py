"""The surface energy balance as a candidate of the criticism (criticism/ranking.py,
``energy_candidate``): tried where the energy check names the surface boundary (or when asked),
scored by the forecast rule like the catalogue, and reported with its figures in the verdict.
Twins from ``pavement_mcmc.synthetic`` (Case C form, one h per interval, loose priors)."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from pavement_mcmc.criticism import diagnose
from pavement_mcmc.criticism.entries import ENERGY, FORECAST_THRESHOLD
from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.criticism.ranking import energy_candidate, rank_missing_effects
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin


def _problem(tmp_path, effect="wind_convection", seed=501, hours=32.0):
    twin = forecast_twins((effect,), (seed,), hours=hours)[0]
    return build_problem(load_case(write_twin(twin, tmp_path / twin.name)))


def test_diagnose_lists_the_energy_balance_and_its_forecast(tmp_path):
    """A 32 h twin with net radiation and wind (24 h fitted, 8 h held out): the diagnosis tries
    the energy balance beside the catalogue, gives its forecast gain against the base model and
    says in the verdict whether it passes the margin, with the figures."""
    pb = _problem(tmp_path)
    base = refit(pb)
    dx = diagnose(pb, base.values(), forecast=True, holdout=False,
                  candidates=["wind_convection", ENERGY])  # named: the rest would cost minutes
    rk = dx.ranking
    e = next((x for x in rk.entries if x.name == ENERGY), None)
    assert e is not None, [x.name for x in rk.entries]
    assert set(e.values) == {"eb_h0", "eb_h1", "eb_alpha"}
    assert e.forecast is not None and math.isfinite(e.forecast_gain)
    assert e.forecast.rmse > 0 and e.forecast.n == rk.forecast.n
    assert "The surface energy balance (energy_balance_window" in rk.verdict
    assert f"F = {e.forecast_gain:.1f}" in rk.verdict
    named = e.detected
    assert ("named by forecast" in rk.verdict) and (("not named by forecast" in rk.verdict)
                                                     is not named)
    assert named == (e.forecast_gain > FORECAST_THRESHOLD and e.score >= -e.threshold
                     and not e.at_bound)
    d = rk.to_dict()
    assert any(c["name"] == ENERGY and c["forecast_gain"] == e.forecast_gain
               for c in d["candidates"])


def test_energy_candidate_only_where_the_surface_is_named_or_asked(tmp_path):
    pb = _problem(tmp_path, hours=16.0)
    wrong = SimpleNamespace(surface_wrong=True)
    fine = SimpleNamespace(surface_wrong=False)
    assert energy_candidate(pb, wrong, None) and energy_candidate(pb, None, True)
    assert not energy_candidate(pb, fine, None) and not energy_candidate(pb, None, None)
    assert not energy_candidate(pb, wrong, False)
    eb = build_problem(pb.cfg, extensions=[ENERGY])  # h(t) already given by a law
    assert not energy_candidate(eb, wrong, True)


def test_a_record_without_net_radiation_skips_it_with_the_reason(tmp_path):
    pb = _problem(tmp_path, hours=16.0)
    dark = replace(pb, model=type(pb.model)(replace(pb.meas, q_net=np.zeros_like(pb.meas.q_net)),
                                            pb.model.grid, pb.model.h_basis))
    rk = rank_missing_effects(dark, None, None, holdout=False, energy_law=True)
    assert ENERGY in rk.skipped and "net radiation" in rk.skipped[ENERGY]
    assert all(e.name != ENERGY for e in rk.entries)


def test_a_plausibility_claim_is_not_worded_as_a_forecast_claim():
    """Under the forecast rule a candidate that brings an impossible kappa, C back into range is
    claimed without forecasting better; the verdict said "by its forecast gain" and "F = 3 > 15"
    (seen on the desert record's base fit, conductivity_temperature)."""
    from pavement_mcmc.criticism.entries import Entry
    from pavement_mcmc.criticism.verdict import forecast_sentence

    e = Entry(name="conductivity_temperature", description="", reference="base", score=1039.0,
              data_score=567.0, delta_chi2=1100.0, delta_prior=0.0, added_params=1.0, rho=0.8,
              rmse=0.41, rmse_sigma=4.1, rmse_sensors=[0.4], evidence=[], values={},
              restores_plausibility=True, forecast_gain=2.6, forecast_rmse_sigma=6.85)
    assert e.detected and e.plausibility_claim and not e.forecasts_better
    fbase = SimpleNamespace(horizon=24.0, rmse_sigma=7.88)
    txt = forecast_sentence(e, [e], fbase)
    assert "not by its forecast" in txt and "F = 2.6 <= 15" in txt and "> 15" not in txt



def test_a_model_whose_h_is_replaced_skips_the_candidates_that_replace_it(tmp_path):
    """The energy balance already in the model (runs/grass_energy.toml): wind_convection, which
    also replaces h(t), is skipped with the reason; it raised "two extensions both replace h(t)"
    and `diagnose runs/grass_energy.toml` stopped."""
    twin = forecast_twins(("wind_convection",), (501,), hours=24.0)[0]
    cfg = load_case(write_twin(twin, tmp_path / twin.name))
    pb = build_problem(cfg, extensions=[ENERGY])
    rk = rank_missing_effects(pb, refit(pb).values(), ["wind_convection", "two_layer"])
    assert "replaces h(t)" in rk.skipped["wind_convection"]
    assert [e.name for e in rk.entries] == ["two_layer"]
