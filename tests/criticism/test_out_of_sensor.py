"""The claim rule's out-of-sensor check (criticism/entries.py, "Out of sensor"): a candidate is
claimed only if its model, refitted without a sensor, predicts that sensor. Twins from
``pavement_mcmc.synthetic`` (the forecast campaign's form: 40 h, Case C, loose priors, input
noise; the inversion shares neither the simulator's grid nor its h(t))."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pavement_mcmc.criticism.entries import LOSO_NONE
from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.criticism.holdout import leave_one_sensor_out, out_of_sensor
from pavement_mcmc.criticism.ranking import rank_missing_effects
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

CANDIDATES = ["two_layer", "sensor_bias", "sensor_depth", "wind_convection"]


def _problem(tmp_path, effect, seed):
    twin = forecast_twins((effect,), (seed,), input_sigma=True)[0]
    pb = build_problem(load_case(write_twin(twin, tmp_path / twin.name)))
    return pb, refit(pb).values()


def test_a_sun_warmed_top_sensor_is_not_claimed_as_a_layer_or_a_sensor_offset(tmp_path):
    """Off-catalogue: the top sensor reads warm in the sun. two_layer forecasts better (F > 15)
    and was claimed before this check; fitted without the top sensor it misses it by more than
    2 sigma, and so does a constant offset of that sensor: no claim, and the verdict says
    where the misfit sits."""
    pb, start = _problem(tmp_path, "sensor_sun", 2801)
    rk = rank_missing_effects(pb, start, CANDIDATES, forecast=True)
    e = {x.name: x for x in rk.entries}
    top = pb.meas.sensor_labels[0]
    assert e["two_layer"].claim_gain > 15.0  # it forecasts better by the margin ...
    assert e["two_layer"].unpredicted is not None  # ... but does not predict the top sensor
    assert e["two_layer"].unpredicted[0] == top and e["two_layer"].unpredicted[1] > LOSO_NONE
    assert rk.best is None
    assert f"the misfit sits in the {top} sensor" in rk.verdict
    assert "none predicts every sensor from the others" in rk.verdict


def test_a_true_sensor_bias_passes_with_its_offsets_held(tmp_path):
    """+0.5 degC on the middle sensor: with the fitted offsets held, every sensor is predicted
    from the others within the limit and sensor_bias is claimed; plain leave-one-sensor-out
    (offsets of the held-out sensor at 0) cannot predict the biased sensor. For the base model
    (no offsets) the check is that plain one."""
    pb, start = _problem(tmp_path, "sensor_bias", 2701)
    rk = rank_missing_effects(pb, start, ["sensor_bias", "two_layer"], forecast=True)
    assert rk.best is not None and rk.best.name == "sensor_bias"
    assert max(rk.best.loso_rmse_sigma.values()) < LOSO_NONE
    fit = rk.best.fit
    held = out_of_sensor(fit.problem, fit.values(), tuple(rk.best.values))
    plain = leave_one_sensor_out(fit.problem, fit.values()).rmse
    mid = int(np.argmax(np.abs([rk.best.values[f"bias_{s}"] for s in pb.meas.sensor_labels])))
    assert held[mid] / pb.meas.sigma < LOSO_NONE < plain[mid] / pb.meas.sigma
    # a model without per-sensor offsets: the check is plain leave-one-sensor-out
    assert out_of_sensor(pb, start) == pytest.approx(leave_one_sensor_out(pb, start).rmse,
                                                      rel=1e-9)



@pytest.mark.parametrize("observed, top, cand", [([2.0], "surface", "wind_convection"),
                                                 ([1.0, 3.0], "measured", "two_layer")])
def test_one_observed_sensor_has_no_out_of_sensor_check(tmp_path, observed, top, cand):
    """With one observed sensor (or two with the top one the measured boundary) there is no
    other sensor to refit to: the check is skipped (no fold, no veto) and the ranking runs as
    before it (it raised an IndexError on the empty fold); holdout's functions say why."""
    twin = forecast_twins((cand,), (2701,))[0]
    inv = {**twin.inversion, "data": {**twin.inversion["data"], "observed_cm": observed},
           "model": {**twin.inversion["model"], "top": top}}
    pb = build_problem(load_case(write_twin(replace(twin, inversion=inv), tmp_path / "t")))
    assert pb.meas.n_sensors == 1
    rk = rank_missing_effects(pb, refit(pb).values(), [cand], forecast=True)
    assert all(e.loso_rmse_sigma is None and e.unpredicted is None for e in rk.entries)
    if top == "surface":  # claimed as before the check
        assert rk.best is not None and rk.best.name == cand
    with pytest.raises(ValueError, match="two observed sensors"):
        out_of_sensor(pb, refit(pb).values())
    with pytest.raises(ValueError, match="two observed sensors"):
        leave_one_sensor_out(pb)


def _entry(name, gain, plausible, fit):
    from pavement_mcmc.criticism.entries import Entry

    return Entry(name=name, description="", reference="base", score=500.0, data_score=100.0,
                 delta_chi2=900.0, delta_prior=400.0, added_params=1.0, rho=0.8, rmse=0.11,
                 rmse_sigma=1.1, rmse_sensors=[0.1, 0.1], evidence=[], values={},
                 restores_plausibility=plausible, forecast_gain=gain, forecast_share=0.9,
                 forecast_rmse_sigma=1.5, excess_share=0.9, fit=fit)


def test_stopped_candidates_keep_their_claim_order(monkeypatch):
    """Each stopped candidate moved behind the claimable ones in front of the earlier stopped
    ones, so the table listed them in reverse (the sun-warmed twin: sensor_bias F = 20 above
    two_layer F = 33). Now: the claimable first, then the stopped in claim order."""
    from types import SimpleNamespace

    from pavement_mcmc.criticism import ranking

    meas = SimpleNamespace(sigma=0.1, sensor_labels=["0cm", "1cm"])
    fit = SimpleNamespace(problem=SimpleNamespace(meas=meas), values=dict)
    a, b, c = (_entry(n, g, False, fit) for n, g in (("a", 40.0), ("b", 30.0), ("c", 20.0)))
    miss = {"a": [0.3, 0.1], "b": [0.1, 0.25], "c": [0.15, 0.1]}  # a, b fail; c passes
    stub = iter(["a", "b", "c"])
    monkeypatch.setattr(ranking, "sensor_holdout", lambda *a: np.array(miss[next(stub)]))
    n = _entry("n", 5.0, False, fit)  # not claimable, never checked
    out = ranking.out_of_sensor(ranking.claim_order([n, c, b, a]))
    assert [e.name for e in out] == ["c", "a", "b", "n"]
    assert c.detected and c.unpredicted is None and n.loso_rmse_sigma is None
