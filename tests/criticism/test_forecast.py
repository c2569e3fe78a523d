"""Forecast skill (criticism/forecast.py): the held-out period is predicted from the forcing
alone, the future rule of h(t), and the claim rule that rests on the forecast (twins from
``pavement_mcmc.synthetic``, Case C form, loose priors)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pavement_mcmc.criticism.forecast import _diurnal_h, forecast, future_values, training_problem
from pavement_mcmc.data import load_case
from pavement_mcmc.physics.hbasis import HBasis
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin


def _problem(tmp_path, effect=None, seed=501, hours=16.0, **kw):
    twin = forecast_twins((effect,) if effect else (), (seed,), hours=hours, **kw)[0]
    return build_problem(load_case(write_twin(twin, tmp_path / twin.name)))


def test_diurnal_rule_is_the_clock_hour_mean_of_the_fitted_h():
    t = np.arange(0.0, 30 * 3600.0 + 1, 1800.0)  # 30 h of 30 min pieces from midnight
    basis = HBasis.per_interval(t)
    mid = 0.5 * (t[1:] + t[:-1]) / 3600.0
    vals = {n: 10.0 + 4.0 * np.sin(2 * np.pi * m / 24.0) + (m > 24) for n, m in
            zip(basis.names, mid, strict=True)}
    d = _diurnal_h(basis, vals, "2004-06-06T00:00:00Z", t[-1])
    for hour in (8, 12, 20):  # covered once: the two pieces of that hour
        want = np.mean([v for m, v in zip(mid, vals.values(), strict=True) if int(m) == hour])
        assert d[hour] == pytest.approx(want, abs=1e-9)
    both = [v for m, v in zip(mid, vals.values(), strict=True) if int(m) % 24 == 2]
    assert d[2] == pytest.approx(np.mean(both), abs=1e-9)  # 02 h on both days: +1 on day 2


def test_forecast_reads_the_forcing_never_a_held_out_temperature(tmp_path):
    pb = _problem(tmp_path)
    fc = forecast(pb)
    assert fc.origins == [12.0] and fc.horizon == 4.0 and fc.n == 8 * pb.meas.n_sensors
    meas = pb.meas
    n0 = meas.n_obs - 9  # the last training row: rows after it are held out
    T = meas.T_obs.copy()
    T[n0 + 1:] += 3.0  # the held-out temperatures change: the prediction may not
    other = replace(pb, model=type(pb.model)(replace(meas, T_obs=T), pb.model.grid,
                                             pb.model.h_basis, pb.model.extensions))
    train_a, train_b = training_problem(pb, n0), training_problem(other, n0)
    np.testing.assert_array_equal(train_a.meas.T_obs, train_b.meas.T_obs)
    vals = future_values(pb, train_a, fc.fits[0].values())
    p = {k: np.array([v]) for k, v in vals.items()}
    pred_a = pb.model.predict(p)[0]
    pred_b = other.model.predict(p)[0]
    np.testing.assert_array_equal(pred_a[n0 + 1:], pred_b[n0 + 1:])
    q = meas.q_net.copy()
    q[n0 + 1:] += 100.0  # the held-out forcing changes: the prediction must
    warm = type(pb.model)(replace(meas, q_net=q), pb.model.grid, pb.model.h_basis)
    assert np.all(warm.predict(p)[0][n0 + 2:, 0] > pred_a[n0 + 2:, 0] + 0.1)
    np.testing.assert_allclose(fc.predicted, pred_a[n0 + 1:], atol=1e-12)


def _rank(tmp_path, effect, candidates, seed=501):
    """The forecast rule's ranking of a 32 h twin (24 h fitted, 8 h held out)."""
    from pavement_mcmc.criticism.fitting import refit
    from pavement_mcmc.criticism.ranking import rank_missing_effects

    pb = _problem(tmp_path, effect, seed, hours=32.0)
    base = refit(pb)
    return rank_missing_effects(pb, base.values(), candidates, holdout=False, forecast=True)


@pytest.mark.parametrize("effect", ["wind_convection"])
def test_a_law_that_forecasts_is_claimed(tmp_path, effect):
    """A wind-driven h fitted in Case C form (one h per interval): in sample the free h(t)
    absorbs it (measured on seed 501: D = -112, the in-sample rule claims nothing), but only
    the law forecasts the held-out 8 h (RMSE 1.46 -> 1.14 sigma, F = 33)."""
    rk = _rank(tmp_path, effect, [effect, "two_layer"])
    assert rk.best is not None and rk.best.name == effect, rk.verdict
    assert rk.best.forecast_rmse_sigma < rk.forecast.rmse_sigma
    assert "forecasts the held-out 8 h" in rk.verdict


def test_an_evaporation_pulse_is_claimed_by_its_forecast(tmp_path):
    """An evaporation pulse after rain, Case C form with input noise on (a campaign twin, 40 h,
    the last 10 h held out): in sample the free h(t) and the inputs' noise absorb it (measured:
    D = -3.5, so the in-sample rule claims nothing, checked here); only the pulse law forecasts
    the held-out hours (RMSE 3.5 -> 1.2 sigma, F = 55)."""
    from pavement_mcmc.criticism.fitting import refit
    from pavement_mcmc.criticism.ranking import rank_missing_effects

    pb = _problem(tmp_path, "evaporation", 700, hours=40.0, input_sigma=True)
    base = refit(pb)
    rank = [rank_missing_effects(pb, base.values(), ["evaporation", "two_layer"], holdout=False,
                                 forecast=fc) for fc in (True, False)]
    assert rank[0].best is not None and rank[0].best.name == "evaporation", rank[0].verdict
    assert rank[0].best.forecast_rmse_sigma < 0.5 * rank[0].forecast.rmse_sigma
    assert rank[1].best is None, rank[1].verdict  # the in-sample rule: not claimed
    assert next(e for e in rank[1].entries if e.name == "evaporation").data_score < 20


#: catalogue effects claimed on fewer than 7 of 10 campaign twins (docs/VALIDATION.md §4): the
#: first three are confounded with kappa, C and a free h(t) under loose priors; the per-sensor
#: ones gain little when the unknown future h dominates the forecast error. (surface_layer left
#: the set when canopy, a layer that stores heat, became a candidate: 16 of 20.)
KNOWN_MISSES = {"radiation_factor", "evapotranspiration", "conductivity_temperature",
                "sensor_bias", "sensor_depth"}


@pytest.mark.slow
def test_forecast_rule_campaign(tmp_path):
    """Issue 22's calibration of the forecast rule (``benchmarks/forecast_campaign.py`` runs the
    same twins resumably, ``--report`` prints this calibration), twice (seed offsets 0 and
    1000): 80 clean twins, 20 of each catalogue effect at 1x, 24 off-catalogue (sun-warmed
    surface sensor, sensor lag, shading, buried source), Case C form, loose priors, input
    noise on. The margin is confirmed on the clean twins of even seed; false claims <= 1/20
    of the clean twins; every effect outside :data:`KNOWN_MISSES` claimed on >= 70 %; the
    fitted true model forecasts within 10 % of the truth-parameter forecast (median). The
    issue's surface-family (>= 80 %) and off-catalogue (>= 9/10) targets are not met:
    docs/VALIDATION.md §4 says why."""
    from pavement_mcmc.criticism.calibration import calibrate
    from pavement_mcmc.criticism.campaign import diagnose_twins, forecast_campaign_twins
    from pavement_mcmc.criticism.entries import FORECAST_THRESHOLD

    twins = forecast_campaign_twins() + forecast_campaign_twins(seed_offset=1000)
    records = diagnose_twins(twins, tmp_path, forecast=True)
    cal = calibrate(records)
    assert cal["margin"] == FORECAST_THRESHOLD, cal["calibration_false"]
    got = cal["at_margin"]
    fa = got["false_claims"]
    assert fa["n"] >= 80 and fa["k"] <= fa["n"] / 20, got["false_claim_twins"]
    missed = {e for e, c in got["effects"].items() if c["k"] < 0.7 * c["n"]}
    assert missed <= KNOWN_MISSES, got["effects"]
    ratio = [r["forecast_ratio"] for r in records if "forecast_ratio" in r]
    assert float(np.median(ratio)) <= 1.10, ratio


def test_a_sun_warmed_surface_sensor_is_not_claimed(tmp_path):
    """Off-catalogue: the surface sensor reads warm in the sun. In sample two_layer passes the
    old rule (measured on seed 501: S = 75, D = 62, the issue's false "partly"); it forecasts
    the held-out 8 h worse (F = -7), so the forecast rule does not claim it."""
    rk = _rank(tmp_path, "sensor_sun", ["two_layer"])
    e = rk.entries[0]
    assert e.data_score > 20 and e.score > 10  # what the in-sample rule claimed
    assert rk.best is None and not e.detected, rk.verdict


def _fc(errors: np.ndarray, sd: float = 0.2):
    """A Forecast of the held-out errors ``errors`` (rows, sensors) scored with plug-in sd ``sd``."""
    from pavement_mcmc.criticism.forecast import Forecast
    from pavement_mcmc.criticism.residuals import pooled_lag1

    lp = -0.5 * (errors / sd) ** 2 - np.log(sd) - 0.5 * np.log(2 * np.pi)
    rmse = float(np.sqrt(np.mean(errors**2)))
    z = np.zeros(0)
    return Forecast("diurnal", [30.0], 10.0, rmse, rmse / sd, [], float(lp.mean()),
                    float(lp.sum()), float(pooled_lag1(errors)), errors.size, z, z, z)


def test_the_forecast_gain_does_not_grow_with_the_unknown_future_h():
    """The gain is the likelihood ratio of the held-out errors with their variance profiled out:
    a candidate that removes 5 % of the forecast's mean square error gains n_eff log(1/0.95)
    whether the errors are 1 sigma or 2.2 sigma (a clean twin's forecast, mostly the unknown
    future h). The plug-in density with the measurement sd reads the second as a gain 5 times
    larger (F = 18 for the first clean twin of the campaign: a false claim)."""
    from pavement_mcmc.criticism.forecast import forecast_gain

    rng = np.random.default_rng(5)
    e = rng.standard_normal((20, 5))
    for scale in (0.2, 0.44):  # forecast errors of 1 and 2.2 sigma
        base, cand = _fc(scale * e), _fc(scale * np.sqrt(0.95) * e)
        phi = (1 + base.rho) / (1 - base.rho)
        assert forecast_gain(base, cand) == pytest.approx(100 / phi * np.log(1 / 0.95), rel=1e-9)
        assert forecast_gain(base, base) == 0.0
    from pavement_mcmc.criticism.forecast import plugin_gain

    big = plugin_gain(_fc(0.44 * e), _fc(0.44 * np.sqrt(0.95) * e))
    small = plugin_gain(_fc(0.2 * e), _fc(0.2 * np.sqrt(0.95) * e))
    assert big / small == pytest.approx(0.44**2 / 0.2**2, rel=1e-9)


def test_the_true_model_fits_a_case_c_twin_to_the_noise(tmp_path):
    """The campaign's truth (true model, true parameters, true h per interval) on a Case C twin
    with input noise: the case names a smoothness precision ``gamma``, which a problem without
    the smoothness prior refused (every clean twin's record failed). Its RMSE is about the
    noise sd, and its forecast is finite."""
    from pavement_mcmc.criticism.campaign import true_rmse, truth_forecast_rmse

    twin = forecast_twins((), (601,), hours=16.0, input_sigma=True)[0]
    cfg = load_case(write_twin(twin, tmp_path / twin.name))
    assert 0.8 * 0.2 < true_rmse(cfg, []) < 1.3 * 0.2
    assert np.isfinite(truth_forecast_rmse(cfg, []))


@pytest.mark.slow
def test_the_fitted_true_model_forecasts_like_the_truth(tmp_path):
    """The score measures the model, not the rule: on clean campaign twins (40 h, input noise,
    the last 10 h held out) the forecast RMSE of the fitted (true) model lies within ~10 % of
    the forecast with the true parameters under the same future rule of h(t)
    (:func:`~pavement_mcmc.criticism.campaign.truth_forecast_rmse`): the median of six within
    10 %, none beyond 30 % (measured on the campaign's clean twins: docs/VALIDATION.md §4)."""
    from pavement_mcmc.criticism.campaign import truth_forecast_rmse
    from pavement_mcmc.criticism.fitting import refit

    ratio = []
    for seed in range(600, 606):
        twin = forecast_twins((), (seed,), hours=40.0, input_sigma=True)[0]
        cfg = load_case(write_twin(twin, tmp_path / twin.name))
        pb = build_problem(cfg)
        fc = forecast(pb, refit(pb).values())
        ratio.append(fc.rmse / truth_forecast_rmse(cfg, [], fc.rule))
    assert np.median(ratio) <= 1.10 and max(ratio) <= 1.30, ratio


def test_the_refits_loose_refinement_reaches_the_same_mode_for_less(tmp_path):
    """The criticism's refits stop the refinement to the mode in log coordinates at a relative
    gain of :data:`~pavement_mcmc.criticism.fitting.REFINE_TOL` (the samplers' starts: 1e-10):
    the objective agrees to within 0.05 (scores are compared to within units) and the fit
    solves fewer parameter sets (a Case C twin with input noise)."""
    from pavement_mcmc.criticism import fitting
    from pavement_mcmc.posterior import find_map

    pb = _problem(tmp_path, "evaporation", 700, hours=24.0, input_sigma=True)
    start = find_map(pb.posterior, max_nfev=100).theta  # a refit starts from a fitted point
    tight = find_map(pb.posterior, start, max_nfev=100)
    loose = find_map(pb.posterior, start, max_nfev=100, refine_tol=fitting.REFINE_TOL)

    def objective(lap):
        th = lap.theta
        rs = pb.posterior.data_residuals(th[None, :])
        return float(np.sum(pb.posterior.whiten(*rs) ** 2)) + fitting.prior_penalty(pb.space, th)

    assert abs(objective(loose) - objective(tight)) < 0.05
    assert loose.n_evals < 0.9 * tight.n_evals
