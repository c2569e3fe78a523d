"""Urban comparison: zero difference when the estimated h IS 4 + 4 v; wind CSV reading."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.analysis.urban import STEFAN_BOLTZMANN, compare, read_wind_csv, standard_h
from pavement_mcmc.cli.simulate import iso_times
from pavement_mcmc.data import load_case
from pavement_mcmc.parameters import parameter_values
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def problem():
    return build_problem(load_case(REPO / "runs" / "caseA.toml"))


def test_standard_h_is_four_plus_four_v_at_interval_midpoints():
    np.testing.assert_allclose(standard_h(np.array([0.0, 1.0, 3.0])), [6.0, 12.0])


def test_zero_difference_when_h_is_the_standard_correlation(problem):
    vals = parameter_values(problem.space, {"kappa": 1.3, "C": 1.0e6})
    h_std = standard_h(problem.meas.wind)
    draws = problem.space.expand(np.tile(problem.space.initial(), (3, 1)))
    c = compare(problem.model, vals, draws=draws, h_override=h_std)
    np.testing.assert_allclose(c.dTs, 0.0, atol=1e-12)
    np.testing.assert_allclose(c.dq_lw, 0.0, atol=1e-9)
    np.testing.assert_allclose(c.dTs_band, 0.0, atol=1e-12)
    assert c.summary()["max_abs_dTs"] < 1e-12


def test_difference_and_long_wave_formula(problem):
    vals = parameter_values(problem.space, {"kappa": 1.3, "C": 1.0e6, "h": 10.0})
    c = compare(problem.model, vals, emissivity=0.9)
    np.testing.assert_allclose(c.h_estimated, 10.0)
    s = c.summary()
    assert s["max_abs_dTs"] > 0.5  # h = 10 vs 4 + 4 v differ by several W m-2 K-1
    K = 273.15
    expect = 0.9 * STEFAN_BOLTZMANN * ((c.Ts_standard + K) ** 4 - (c.Ts_estimated + K) ** 4)
    np.testing.assert_allclose(c.dq_lw, expect)
    # a stronger h ties the surface to the air: with h = 4 + 4 v < 10 at noon, T_s is warmer
    i = int(np.argmax(problem.meas.q_net))
    assert (c.h_standard[i - 1] < 10) == (c.dTs[i] > 0)


def test_wind_csv(tmp_path, problem):
    meas = problem.meas
    times = iso_times(meas)
    p = tmp_path / "airport.csv"
    rows = ["time,wind"] + [f"{t},{2.0 + (i % 2)}" for i, t in enumerate(times)]
    p.write_text("\n".join(rows) + "\n")
    w = read_wind_csv(p, meas)
    np.testing.assert_allclose(w, 2.0 + (np.arange(meas.n_obs) % 2))
    hours = tmp_path / "hours.csv"
    hours.write_text("time,wind\n0,1\n100,3\n")
    np.testing.assert_allclose(read_wind_csv(hours, meas)[-1], 1 + 2 * meas.t[-1] / 3600 / 100)
    bad = tmp_path / "bad.csv"
    bad.write_text("time,speed\n0,1\n")
    with pytest.raises(ValueError, match="'time' and 'wind'"):
        read_wind_csv(bad, meas)
    short = tmp_path / "short.csv"
    short.write_text("time,wind\n0,1\n5,2\n")
    with pytest.raises(ValueError, match="does not cover"):
        read_wind_csv(short, meas)
    nan = tmp_path / "nan.csv"
    nan.write_text("time,wind\n0,1\n100,x\n")
    with pytest.raises(ValueError, match="data row 2"):
        read_wind_csv(nan, meas)


def test_compare_errors(problem):
    vals = parameter_values(problem.space, {})
    with pytest.raises(ValueError, match="emissivity"):
        compare(problem.model, vals, emissivity=1.5)
    with pytest.raises(ValueError, match="shape"):
        compare(problem.model, vals, wind=np.ones(3))
