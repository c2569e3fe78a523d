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
