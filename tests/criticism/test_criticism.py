"""Fast checks of the criticism's statistics against answers that do not come from the code."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.criticism import analyse, finer_h_spec, ledger, refit
from pavement_mcmc.criticism.residuals import harmonic, lag1, ljung_box
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem


def test_lag1_of_ar1():
    rng = np.random.default_rng(0)
    x = np.zeros(20000)
    e = rng.standard_normal(x.size)
    for i in range(1, x.size):
        x[i] = 0.7 * x[i - 1] + e[i]
    assert lag1(x) == pytest.approx(0.7, abs=0.02)


def test_ljung_box_white_vs_ar1():
    rng = np.random.default_rng(1)
    white = rng.standard_normal(500)
    ps = [ljung_box(rng.standard_normal(200))[1] for _ in range(200)]
    assert 0.02 < np.mean(np.array(ps) < 0.05) < 0.10  # calibrated under the null
    ar = np.convolve(white, np.ones(4) / 4, mode="valid")
    assert ljung_box(ar)[1] < 1e-6


def test_harmonic_amplitude_and_phase():
    t = np.arange(0, 2 * 86400, 900.0)
    y = 3.0 * np.cos(2 * np.pi * (t - 15 * 3600) / 86400) + 0.5 + 1e-6 * t
    amp, phase = harmonic(t, y)
    assert amp == pytest.approx(3.0, rel=1e-6)
    assert phase / 3600 == pytest.approx(15.0, abs=1e-4)


@pytest.fixture(scope="module")
def problem():
    return build_problem(load_case("runs/hidden.toml"))


def test_analyse_recovers_an_injected_bias_and_phase(problem):
    meas = problem.meas
    rng = np.random.default_rng(2)
    pred = meas.T_obs + rng.normal(0, meas.sigma, meas.T_obs.shape)
    pred[:, 2] += 0.6  # an offset at one sensor
    rep = analyse(meas, pred)
    s = rep.sensors
    assert s[2].bias == pytest.approx(0.6, abs=0.05)
    assert all(abs(x.bias) < 0.06 for i, x in enumerate(s) if i != 2)
    assert all(abs(x.lag1) < 0.25 for x in s)
    assert all(x.amp_ratio == pytest.approx(1.0, abs=0.05) for x in s)
    # a model that is 1 h late at every depth
    late = np.stack(
        [np.interp(meas.t - 3600, meas.t, meas.T_obs[:, k]) for k in range(meas.n_sensors)], axis=1
    )
    rep2 = analyse(meas, late)
    assert all(x.phase_error_h == pytest.approx(1.0, abs=0.15) for x in rep2.sensors[:3])


def test_finer_h_spec(problem):
    spec = finer_h_spec(problem)
    assert len(spec["edges_hours"]) - 1 == 2 * len(problem.model.h_basis.names)
    cfg = load_case("runs/caseA.toml")
    a = build_problem(cfg)
    edges = finer_h_spec(a)["edges_hours"]
    assert np.max(np.diff(edges)) <= 2.0 + 1e-9 and len(edges) - 1 == 14


def test_refit_and_ledger_fall(problem):
    base = refit(problem)
    cfg = problem.cfg
    two = build_problem(cfg, extensions=["two_layer"])
    fit2 = refit(two, {**base.values(), "kappa2": 0.8, "C2": 1.2e6, "d_layer": 0.02})
    assert fit2.rmse < 0.75 * base.rmse  # the shipped dataset hides a two-layer ground
    led = ledger([("base", problem, base.values()), ("two_layer", two, fit2.values())], holdout=False)
    d = led.deltas()[1]
    assert d["rmse"] < 0 and d["lag1"] < 0
    assert "two_layer" in led.text()


def test_a_diagnosis_analyses_its_point_once(problem, monkeypatch):
    """diagnose() computed the residual report of the point estimate, then the ranking computed
    it again; the ranking now takes the diagnosis' report (same numbers, one analysis)."""
    import importlib

    from pavement_mcmc.criticism import diagnose

    dmod = importlib.import_module("pavement_mcmc.criticism.diagnose")  # the name is the function
    rmod = importlib.import_module("pavement_mcmc.criticism.ranking")

    calls = []

    def counted(module):
        real = module.analyse_point

        def wrapper(pb, values):
            calls.append((pb, dict(values)))
            return real(pb, values)

        monkeypatch.setattr(module, "analyse_point", wrapper)

    counted(dmod)
    counted(rmod)
    point = refit(problem).values()
    dx = diagnose(problem, point, candidates=["sensor_bias"], holdout=False)
    assert sum(pb is problem and v == point for pb, v in calls) == 1
    assert dx.ranking.residuals is dx.residuals
