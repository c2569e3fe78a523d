"""Field-like twins (2-50 cm sensors, 30 min, spring over grass) and heat-flux plates.

The plates' true flux is checked against the energy it must carry (heat content change below it
plus the flux out further down), their noise against its stated model, and the field geometry's
default grid against a finer one and against what the Goettingen grass record shows.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pavement_mcmc.synthetic import SyntheticSpec, flux_columns, resolved_grid, simulate
from pavement_mcmc.synthetic.corpus import FIELD, field_h_knots

GRASS = {"evapotranspiration": {}, "surface_layer": {}}
FIELD_72H = SyntheticSpec(seed=7, hours=72.0, h_knots=field_h_knots(72.0), effects=GRASS, **FIELD)


@pytest.fixture(scope="module")
def grass():
    return simulate(FIELD_72H)


def test_grid_defaults_depend_on_the_geometry():
    assert resolved_grid(SyntheticSpec()) == (0.00025, 5.0)  # the paper's 0-5 cm: unchanged
    assert resolved_grid(FIELD_72H) == (0.001, 30.0)
    assert resolved_grid(replace(FIELD_72H, dz_mm=0.5, dt_s=10.0)) == (0.0005, 10.0)


def test_field_default_grid_is_converged(grass):
    """Halving the cells and a third of the time step moves the temperatures by << sigma
    (measured 2.3e-3 degC against 0.25 mm / 5 s; the lagged ET closure relaxes per step) and
    the plate's flux by < 0.5 W m-2."""
    _, coarse = grass
    _, fine = simulate(replace(FIELD_72H, dz_mm=0.5, dt_s=10.0))
    assert np.abs(fine.T_clean - coarse.T_clean).max() < 0.01
    assert np.abs(fine.flux["G_5cm"] - coarse.flux["G_5cm"]).max() < 0.5
    assert coarse.dz == 0.001 and coarse.dt == 30.0 and fine.dt == 10.0


def test_grass_twin_looks_like_the_grass_record(grass):
    """The Goettingen record (README): the 2 cm peak lags q_net by ~3.5 h, the ground heat flux
    is 5-20 % of net radiation at midday, T_2cm spans a few degC a day in early April."""
    columns, truth = grass
    t_h = truth.t / 3600.0
    for day in range(3):
        d = (t_h >= 24 * day) & (t_h < 24 * (day + 1))
        lag = t_h[d][np.argmax(truth.T_clean[d, 0])] - t_h[d][np.argmax(columns["q_net"][d])]
        assert 2.0 <= lag <= 5.0  # measured 3.0 h on day 2
        assert 2.0 < np.ptp(truth.T_clean[d, 0]) < 10.0  # measured 4.5 degC
        assert 0.04 < truth.flux["G_5cm"][d].max() / columns["q_net"][d].max() < 0.25
    assert truth.q_et.max() > 100.0 and truth.q_et.min() >= 0.0
    assert -5.0 < columns["T_air"].min() and columns["T_air"].max() < 22.0


def test_flux_plate_closes_the_energy_budget():
    """G(5 cm) - G(80 cm) = d/dt of the heat held between 5 and 80 cm.

    Integrated over the rows with the trapezoid rule, whose relative error for a harmonic of
    period P sampled every 30 min is (2 pi 30 min / P)^2 / 12: 0.14 % for the daily wave, 0.6 %
    for a 12 h one. Tolerances: 0.5 % of the heat that passed the plate, cumulatively, and 3 % of
    the flux's RMS per 30 min interval (measured 0.02 % and 0.6 %). A flux taken 1.5 cm off (the
    thatch offset forgotten) fails both (measured 2 % and 20 %), and so would a wrong sign or
    kappa(T) left out of the flux (measured 0.8 % and 6 %)."""
    effects = {**GRASS, "conductivity_temperature": {}}
    spec = replace(FIELD_72H, effects=effects, flux_depths_cm=(3.5, 5.0, 80.0))
    _, truth = simulate(spec)
    a, b = truth.soil_top + 0.05, truth.soil_top + 0.80
    inner = truth.z[(truth.z > a) & (truth.z < b)]
    z = np.concatenate(([a], inner, [b]))
    heat = FIELD["C"] * np.trapezoid([np.interp(z, truth.z, p) for p in truth.profiles], z, axis=1)
    dt = np.diff(truth.t)

    def misfit(upper: str) -> tuple[float, float]:
        net = truth.flux[upper] - truth.flux["G_80cm"]
        passed = 0.5 * (net[1:] + net[:-1]) * dt
        cumulative = np.abs(np.cumsum(passed) - (heat[1:] - heat[0])).max()
        total = np.sum(0.5 * np.abs(truth.flux["G_5cm"][1:] + truth.flux["G_5cm"][:-1]) * dt)
        per_step = np.sqrt(np.mean((np.diff(heat) / dt - passed / dt) ** 2))
        return cumulative / total, per_step / np.sqrt(np.mean(truth.flux["G_5cm"] ** 2))

    cumulative, per_step = misfit("G_5cm")
    assert cumulative < 0.005 and per_step < 0.03
    cumulative, per_step = misfit("G_3.5cm")  # sits at 5 cm in the column: ignores the thatch
    assert cumulative > 0.01 and per_step > 0.1


def test_plate_readings_follow_their_error_model(grass):
    """reading = factor x G (1 + 0.05 N1) + 2 N2, from a stream of their own."""
    columns0, truth0 = grass
    spec = replace(FIELD_72H, hours=168.0, h_knots=field_h_knots(168.0), plate_factor=0.8)
    columns, truth = simulate(spec)
    G = truth.flux["G_5cm"]
    r = columns["G_5cm"] - 0.8 * G
    z = r / np.sqrt((0.8 * 0.05 * G) ** 2 + 2.0**2)
    assert z.size == 337
    assert np.std(z) == pytest.approx(1.0, abs=0.12) and abs(np.mean(z)) < 0.15
    assert np.corrcoef(columns["G_5cm"], G)[0, 1] > 0.95
    # the plates change nothing else: temperatures and forcing identical without them
    bare, _ = simulate(replace(FIELD_72H, flux_depths_cm=()))
    assert "G_5cm" not in bare and flux_columns(FIELD_72H) == ["G_5cm"]
    for name in bare:
        np.testing.assert_array_equal(bare[name], columns0[name])
    # noise off: the reading is the calibrated true flux
    exact, truth = simulate(replace(FIELD_72H, plate_rel_noise=0.0, plate_abs_noise=0.0, plate_factor=0.8))
    np.testing.assert_allclose(exact["G_5cm"], 0.8 * truth.flux["G_5cm"], rtol=1e-14)


def test_plate_depths_are_checked():
    with pytest.raises(ValueError, match="flux_depths_cm"):
        simulate(replace(FIELD_72H, flux_depths_cm=(-1.0,)))
    with pytest.raises(ValueError, match="same depth twice"):
        simulate(replace(FIELD_72H, flux_depths_cm=(5.0, 5.0)))
    with pytest.raises(ValueError, match="plate_factor"):
        simulate(replace(FIELD_72H, plate_factor=0.0))
