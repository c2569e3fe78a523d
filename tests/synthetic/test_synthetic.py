"""Tests of the independent twin-data generator against analytical answers and its own promises."""

from __future__ import annotations

import csv
import json
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from pavement_mcmc.synthetic import (
    DEFAULT_RAIN,
    EFFECTS,
    SyntheticSpec,
    simulate,
    temperature_columns,
    to_measurements,
    write_case,
)
from pavement_mcmc.synthetic.column import (
    STEFAN_BOLTZMANN,
    integrate,
    layered_column,
    stretched_nodes,
)

KAPPA, C = 1.31, 0.99e6
OBSERVED = [f"T_{d}cm" for d in range(5)]


def _observed(columns: dict) -> np.ndarray:
    return np.stack([columns[c] for c in OBSERVED], axis=1)


@pytest.fixture(scope="module")
def base() -> dict:
    """No-effect datasets with seed 3, without and with the default shower."""
    return {rain: simulate(SyntheticSpec(seed=3, rain=rain)) for rain in ((), DEFAULT_RAIN)}


# --- the numerical core against analytical solutions -------------------------------------------


def test_steady_state_two_layers_kappa_of_T_and_emission_is_exact():
    """Constant forcing: the steady profile solves a scalar equation (Kirchhoff transform)."""
    L, d, k1, k2, beta = 0.3, 0.02, KAPPA, 0.6 * KAPPA, -0.005
    T_air, h, q_abs, eps, T_deep = 25.0, 12.0, 900.0, 0.95, 22.0
    z = stretched_nodes(0.07, L, 0.0005)
    column = layered_column(z, np.array([d]), np.array([k1, k2]), np.array([C, 1.3 * C]))
    n = 400  # A-stable BDF2: huge steps march straight to the steady state
    const = np.ones(n + 1)
    T = integrate(
        column,
        np.full(z.size, T_deep),
        3600.0,
        T_air * const,
        h * const,
        q_abs * const,
        0 * const,
        T_deep * const,
        emissivity=eps,
        beta=beta,
    )[-1]

    def phi(T):  # Kirchhoff potential of kappa(T) = kappa (1 + beta (T - 20))
        return (T - 20.0) + 0.5 * beta * (T - 20.0) ** 2

    resistance = d / k1 + (L - d) / k2

    def balance(Ts):
        flux_in = q_abs - eps * STEFAN_BOLTZMANN * (Ts + 273.15) ** 4 + h * (T_air - Ts)
        return flux_in * resistance - (phi(Ts) - phi(T_deep))

    Ts = brentq(balance, T_deep, 80.0)
    flux = (phi(Ts) - phi(T_deep)) / resistance
    # interface: flux d / k1 = phi(Ts) - phi(Ti)
    Ti = brentq(lambda x: flux * d / k1 - (phi(Ts) - phi(x)), T_deep, Ts)
    assert Ts - T_deep > 20.0  # a strongly non-trivial state
    assert T[0] == pytest.approx(Ts, abs=1e-6)
    assert np.interp(d, z, T) == pytest.approx(Ti, abs=1e-6)


def test_periodic_forcing_matches_semi_infinite_solution():
    """Robin surface with periodic T_air and q: amplitude exp(-x/delta), lag x/delta, and the
    surface amplitude (h A + Q) / (h + kappa (1 + i) / delta)."""
    period = 6 * 3600.0
    omega = 2 * np.pi / period
    delta = np.sqrt(2 * KAPPA / (C * omega))  # 9.5 cm
    h, A, Q = 10.0, 5.0, -300j  # T_air = 20 + 5 cos(wt), q = 300 sin(wt)
    theta0 = (h * A + Q) / (h + KAPPA * (1 + 1j) / delta)
    z = stretched_nodes(0.07, 1.0, 0.00025)  # 1 m >> delta: semi-infinite
    column = layered_column(z, np.array([]), np.array([KAPPA]), np.array([C]))

    def exact(t):
        return 20.0 + np.real(theta0 * np.exp(-(1 + 1j) * z[:, None] / delta + 1j * omega * t)).T

    dt = 5.0
    t = np.arange(int(2 * period / dt) + 1) * dt
    T = integrate(
        column,
        exact(np.array([0.0]))[0],
        dt,
        20 + A * np.cos(omega * t),
        np.full(t.size, h),
        300 * np.sin(omega * t),
        np.zeros(t.size),
        np.full(t.size, 20.0),
        record_every=36,
    )
    t_rec = t[::36]
    sensors = [int(np.argmin(abs(z - x))) for x in (0.0, 0.01, 0.02, 0.03, 0.04)]
    err = T[:, sensors] - exact(t_rec)[:, sensors]
    assert np.abs(err).max() < 0.005 * abs(theta0)  # |theta0| ~ 11 K
    # complex amplitudes over the last period: decay and lag exactly as exp(-(1 + i) x / delta)
    last = t_rec >= period
    w = np.exp(-1j * omega * t_rec[last][:-1])
    amp = 2 * (T[last][:-1][:, sensors] - 20.0).T @ w / w.size
    x = z[sensors]
    ratio = amp / amp[0]
    np.testing.assert_allclose(np.abs(ratio), np.exp(-x / delta), rtol=2e-3)
    np.testing.assert_allclose(-np.angle(ratio), x / delta, atol=2e-3)
    assert abs(amp[0] - theta0) < 2e-3 * abs(theta0)


def test_grid_and_time_step_convergence():
    """Halving the cells and the time step moves the 0-5 cm temperatures by << 0.01 degC."""
    spec = SyntheticSpec(seed=1, sigma=0.0, effects={"two_layer": {}, "conductivity_temperature": {}})
    _, coarse = simulate(spec)
    _, fine = simulate(replace(spec, dz_mm=0.125, dt_s=2.5))
    assert np.abs(fine.T_clean - coarse.T_clean).max() < 0.001  # measured 1.3e-4
    assert np.ptp(coarse.T_clean[:, 0]) > 25.0  # a real diurnal cycle was simulated


def test_dirichlet_at_5cm_is_the_same_physical_problem():
    """Re-solving only 0-5 cm with the recorded 5 cm series as boundary, the recorded forcing
    interpolated linearly and the true h reproduces the 0-4 cm temperatures (what the inversion
    solver is compared against)."""
    spec = SyntheticSpec(seed=5, sigma=0.0, forcing_noise=False, emission=False, forcing="linear")
    columns, truth = simulate(spec)
    dt = 5.0
    t = np.arange(0.0, truth.t[-1] + 1e-9, dt)
    z = stretched_nodes(0.05, 0.05, 0.0005)
    column = layered_column(z, np.array([]), np.array([KAPPA]), np.array([C]))
    T = integrate(
        column,
        np.interp(z, truth.z, truth.T_initial),
        dt,
        np.interp(t, truth.t, columns["T_air"]),
        np.interp(t, truth.t, truth.h_obs),
        np.interp(t, truth.t, columns["q_net"]),
        np.zeros(t.size),
        np.interp(t, truth.t, columns["T_5cm"]),
        record_every=180,
    )
    pred = np.stack([[np.interp(x, z, row) for x in (0, 0.01, 0.02, 0.03, 0.04)] for row in T])
    err = pred - truth.T_clean[:, :5]
    assert np.sqrt(np.mean(err**2)) < 0.01
    assert np.abs(err).max() < 0.03


# --- datasets ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name", EFFECTS)
def test_each_effect_is_detectable_but_realistic(name, base):
    rain = DEFAULT_RAIN if name == "evaporation" else ()
    columns, truth = simulate(SyntheticSpec(seed=3, rain=rain, effects={name: {}}))
    columns0, truth0 = base[rain]
    diff = _observed(columns) - _observed(columns0)
    rms = np.sqrt(np.mean(diff**2))
    assert 0.1 < rms < 3.0, f"{name}: RMS change {rms:.3f} degC"
    assert set(truth.effects) == {name}
    np.testing.assert_array_equal(columns["wind"], columns0["wind"])  # same weather
    np.testing.assert_array_equal(columns["rain"], columns0["rain"])


def test_effect_signatures(base):
    columns0, truth0 = base[()]
    # a bias moves one sensor by exactly its value
    columns, _ = simulate(SyntheticSpec(seed=3, rain=(), effects={"sensor_bias": {}}))
    np.testing.assert_allclose(
        _observed(columns) - _observed(columns0), [[0, 0, 0.5, 0, 0]] * 113, atol=1e-12
    )
    # depth offsets leave the bottom sensor alone; a deeper sensor is damped and lagged (cooler
    # than nominal at the afternoon peak)
    columns, truth = simulate(SyntheticSpec(seed=3, rain=(), effects={"sensor_depth": {}}))
    np.testing.assert_array_equal(columns["T_5cm"], columns0["T_5cm"])
    noon = np.argmax(truth0.T_clean[:, 3])
    assert truth.T_clean[noon, 3] < truth0.T_clean[noon, 3] - 0.1  # 3 cm sensor at 3.5 cm
    # wind-driven h follows the recorded wind
    columns, truth = simulate(SyntheticSpec(seed=3, rain=(), effects={"wind_convection": {}}))
    np.testing.assert_allclose(truth.h_obs, 4 + 3 * columns["wind"], atol=0.016)
    # the ground absorbs f x (recorded q_net)
    spec = SyntheticSpec(seed=3, rain=(), forcing_noise=False, effects={"radiation_factor": {}})
    columns, truth = simulate(spec)
    np.testing.assert_allclose(truth.q_ground, 0.85 * columns["q_net"], rtol=1e-12)
    # the latent sink follows the catalogue formula at the row times
    columns, truth = simulate(SyntheticSpec(seed=3, effects={"evaporation": {}}))
    t_h, r = truth.t / 3600, columns["rain"]
    expected = [30 * np.sum(r[: k + 1] * np.exp(-(t_h[k] - t_h[: k + 1]) / 3)) for k in range(113)]
    np.testing.assert_allclose(truth.q_evap, expected, rtol=1e-12)
    assert r.sum() == pytest.approx(4.0) and truth.q_evap.max() > 50


def test_effect_parameters_are_checked():
    with pytest.raises(ValueError, match="valid effects: two_layer, sensor_depth"):
        simulate(SyntheticSpec(effects={"two_layers": {}}))
    with pytest.raises(ValueError, match="unknown parameter"):
        simulate(SyntheticSpec(effects={"two_layer": {"depth": 0.02}}))
    with pytest.raises(ValueError, match="valid: .'bias_0cm', 'bias_1cm'"):
        simulate(SyntheticSpec(effects={"sensor_bias": {"bias_5cm": 0.5}}))
    with pytest.raises(ValueError, match="below the bottom"):
        simulate(SyntheticSpec(effects={"sensor_depth": {"dz_4cm": 0.012}}))
    with pytest.raises(ValueError, match="needs rain"):
        simulate(SyntheticSpec(rain=(), effects={"evaporation": {}}))


def test_noise_matches_sigma_and_forcing_is_plausible(base):
    columns, truth = base[()]
    names = temperature_columns(SyntheticSpec())
    residual = np.stack([columns[c] for c in names], axis=1) - truth.T_clean
    assert np.std(residual) == pytest.approx(0.2, rel=0.08)
    assert abs(np.mean(residual)) < 0.03
    assert truth.noise_rms == pytest.approx(0.2, rel=0.1)
    assert 10 < columns["T_air"].min() and columns["T_air"].max() < 30
    assert -150 < columns["q_net"].min() < -30 and 350 < columns["q_net"].max() < 700
    assert 40 < truth.T_clean[:, 0].max() < 65  # summer asphalt surface
    # the initial profile is not linear (spin-up)
    x = np.linspace(0, 0.05, 51)
    T0 = np.interp(x, truth.z, truth.T_initial)
    assert np.abs(T0 - np.interp(x, [0, 0.05], T0[[0, -1]])).max() > 0.05  # ~0.1 at midnight


def test_reproducible_by_seed():
    a, ta = simulate(SyntheticSpec(seed=7))
    b, tb = simulate(SyntheticSpec(seed=7))
    c, _ = simulate(SyntheticSpec(seed=8))
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])
    np.testing.assert_array_equal(ta.T_clean, tb.T_clean)
    assert not np.allclose(a["T_0cm"], c["T_0cm"])


def test_csv_round_trip(tmp_path):
    spec = SyntheticSpec(seed=2, effects={"two_layer": {}, "sensor_bias": {}})
    path = write_case(spec, tmp_path / "case")
    columns, truth = simulate(spec)
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time", "T_air", "q_net", "wind", "rain", *temperature_columns(spec)]
    table = dict(zip(rows[0], zip(*rows[1:], strict=True), strict=True))
    assert list(table["time"]) == list(columns["time"])
    for name in rows[0][1:]:
        np.testing.assert_allclose(np.asarray(table[name], float), columns[name], atol=0.05001)
    for name in temperature_columns(spec):
        np.testing.assert_allclose(np.asarray(table[name], float), columns[name], atol=0.005001)
    record = json.loads((tmp_path / "case" / "truth.json").read_text())
    reference_keys = [
        "kappa",
        "C",
        "sigma",
        "h_true_obs",
        "layer",
        "sensor_depth",
        "h_wind",
        "evap",
        "bias",
        "rad_error",
        "k_temp",
        "rmse_noise_only",
    ]
    assert set(reference_keys) <= set(record)
    assert record["layer"]["d_layer"] == 0.02 and record["h_wind"] is None
    assert len(record["h_true_obs"]) == len(rows) - 1
    assert record["effects"]["sensor_bias"] == {
        "bias_0cm": 0,
        "bias_1cm": 0,
        "bias_2cm": 0.5,
        "bias_3cm": 0,
        "bias_4cm": 0,
    }


def test_irregular_sampling_and_measurements():
    spec = SyntheticSpec(seed=4, drop_fraction=0.3, rain=DEFAULT_RAIN)
    columns, truth = simulate(spec)
    meas = to_measurements(columns, sigma=spec.sigma)
    steps = np.diff(meas.t)
    assert np.all(steps > 0) and steps.max() > 900 and np.all(steps % 900 == 0)
    assert 60 < meas.n_obs < 100 and meas.t[-1] == 28 * 3600
    assert columns["rain"].sum() == pytest.approx(4.0)  # rain of dropped rows is carried over
    np.testing.assert_allclose(meas.depths, [0, 0.01, 0.02, 0.03, 0.04])
    assert meas.bottom_depth == 0.05 and meas.T_obs.shape == (meas.n_obs, 5)
    np.testing.assert_array_equal(meas.T_bottom, columns["T_5cm"])
    np.testing.assert_allclose(meas.initial_profile(meas.depths), meas.T_obs[0])
    assert truth.h_obs.shape == meas.t.shape == truth.t.shape
