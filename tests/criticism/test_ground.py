"""The ground forecast (criticism/ground.py): the deeper sensors predicted from the measured top
sensor, and the calibration's ground variants of the claim rule (twins from
``pavement_mcmc.synthetic``, Case C form, loose priors; the inversion does not share the
simulator's grid or h(t))."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.criticism.calibration import claim_at, gain
from pavement_mcmc.criticism.campaign import _true_values
from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.criticism.forecast import forecast
from pavement_mcmc.criticism.ground import ground_errors, ground_forecast, ground_gain, ground_model
from pavement_mcmc.criticism.ranking import rank_missing_effects
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin


def _case(tmp_path, effect, seed=501, hours=24.0):
    twin = forecast_twins((effect,), (seed,), hours=hours)[0]
    return load_case(write_twin(twin, tmp_path / twin.name))


def test_ground_forecast_of_the_true_model_matches_the_truth_and_beats_the_base(tmp_path):
    """+0.5 degC on the middle sensor: the fitted true model's ground forecast is within 10 % of
    the truth-parameter one, the base model's clearly worse, and the gain says so."""
    cfg = _case(tmp_path, "sensor_bias")
    base = build_problem(cfg)
    true = build_problem(cfg, extensions=["sensor_bias"], grid=base.model.grid)
    fb, ft = forecast(base, refit(base).values()), forecast(true, refit(true).values())
    gb, gt = ground_forecast(base, fb), ground_forecast(true, ft)
    pb, vals = _true_values(cfg, ["sensor_bias"])
    ideal = float(np.sqrt(np.mean(ground_errors(pb, vals, ft.origins[-1], ft.horizon) ** 2)))
    assert gt.rmse == pytest.approx(ideal, rel=0.1)
    assert gb.rmse > 1.3 * ideal
    assert gt.n == fb.n - fb.n // cfg.measurements.n_sensors  # the top sensor is not scored
    assert ground_gain(gb, gt) > 15.0


def test_ground_model_uses_the_candidates_top_sensor_and_drops_the_surface(tmp_path):
    """The boundary is the top reading minus its fitted bias, at its fitted depth; a layer
    interface stays at its depth below the surface; surface effects are not in the model."""
    cfg = _case(tmp_path, "two_layer")
    meas = cfg.measurements
    top = meas.sensor_labels[0]
    pb = build_problem(cfg, extensions=["sensor_bias", "sensor_depth", "two_layer",
                                        "wind_convection"])
    vals = {f"bias_{top}": 0.7, f"dz_{top}": 0.004, "d_layer": 0.03, "kappa": 1.2}
    g, p = ground_model(pb.model, vals)
    assert g.top_measured and [e.name for e in g.extensions] == [
        "sensor_bias", "sensor_depth", "two_layer"]
    np.testing.assert_allclose(g.meas.T_top, meas.T_obs[:, 0] - 0.7)
    np.testing.assert_allclose(g.meas.depths, meas.depths[1:] - meas.depths[0] - 0.004)
    assert g.meas.sensor_labels == meas.sensor_labels[1:]  # the deeper sensors keep their names
    assert p["d_layer"][0] == pytest.approx(0.03 - meas.depths[0] - 0.004)
    assert p["kappa"][0] == 1.2
    with pytest.raises(ValueError, match="surface-driven"):
        ground_model(g, vals)


def test_ground_variants_of_the_claim_rule_read_G_only_for_ground_candidates():
    e = {"S": 0.0, "at_bound": [], "profile": False, "explains": True, "partial": False,
         "detected": True, "plausibility": False}
    rec = {"entries": {"sensor_bias": dict(e, F=2.0, G=40.0, ground=True),
                       "wind_convection": dict(e, F=12.0, G=90.0, ground=False),
                       "two_layer": dict(e, F=30.0, G=-5.0, ground=True)}}
    assert claim_at(rec, 15.0) == "two_layer"
    assert claim_at(rec, 15.0, ground="either") == "sensor_bias"
    assert claim_at(rec, 15.0, ground="only") == "sensor_bias"
    assert gain(rec["entries"]["two_layer"], "only") == -5.0
    assert gain(rec["entries"]["wind_convection"], "either") == 12.0  # a surface effect: F
    with pytest.raises(ValueError, match="unknown ground rule"):
        gain(rec["entries"]["two_layer"], "both")


def test_ranking_claims_a_deeper_sensor_bias_by_the_ground_forecast(tmp_path):
    """A +0.5 degC bias on the middle sensor, 40 h: the forcing forecast cannot see it under the
    unknown future h (F ~ 0, no claim), the ground forecast credits it and the verdict says so;
    a surface candidate gets no ground gain."""
    cfg = _case(tmp_path, "sensor_bias", hours=40.0)
    pb = build_problem(cfg)
    start = refit(pb).values()
    cands = ["sensor_bias", "two_layer", "wind_convection"]
    plain = rank_missing_effects(pb, start, cands, forecast={"ground": False})
    assert plain.best is None
    rk = rank_missing_effects(pb, start, cands, forecast={"ground": True})
    e = {x.name: x for x in rk.entries}
    assert rk.best is not None and rk.best.name == "sensor_bias" and rk.best.by_ground
    assert e["sensor_bias"].forecast_gain < 15.0 < e["sensor_bias"].ground_gain
    assert e["wind_convection"].ground_gain is None
    assert "from the measured top sensor" in rk.verdict and "ground gain G" in rk.verdict


def test_a_candidate_that_moves_the_top_sensor_past_the_next_has_no_ground_gain(tmp_path):
    """A sensor_depth fit with the top sensor's offset at its +1 cm bound puts it at the next
    sensor's depth: its ground forecast is undefined. The ranking leaves its ground gain out
    (the forecast campaign stopped with a ValueError on such a twin)."""
    from types import SimpleNamespace

    from pavement_mcmc.criticism.ranking import _ground_gains

    cfg = _case(tmp_path, "sensor_depth")
    base = build_problem(cfg)
    fit = refit(base)
    fb = forecast(base, fit.values())
    cand = build_problem(cfg, extensions=["sensor_depth"], grid=base.model.grid)
    vals = {**cand.space.value_dict(), **fit.values()}
    top = cand.meas.sensor_labels[0]
    vals[f"dz_{top}"] = float(cand.meas.depths[1] - cand.meas.depths[0])
    with pytest.raises(ValueError, match="at or above the top sensor"):
        ground_model(cand.model, vals)
    fc = SimpleNamespace(fits=[SimpleNamespace(values=lambda: vals)], origins=fb.origins,
                         horizon=fb.horizon)
    e = SimpleNamespace(hook="observe", fit=SimpleNamespace(problem=cand), forecast=fc,
                        ground_gain=None, ground_rmse_sigma=None)
    _ground_gains(SimpleNamespace(problem=base), fb, [e])
    assert fb.ground is not None and e.ground_gain is None
    # and the campaign's records of the same ranking (its slow test stopped there too)
    from pavement_mcmc.criticism.campaign import _ground_records

    e.name = "sensor_depth"
    rec = {"entries": {"sensor_depth": {}}}
    _ground_records(base, SimpleNamespace(forecast=fb, entries=[e]), rec)
    assert "ground_rmse_sigma" in rec and rec["entries"]["sensor_depth"] == {}
