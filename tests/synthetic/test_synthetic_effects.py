"""The twin simulator's new hidden effects: each moves the clean temperatures the way its physics
says, leaves the weather and the noise alone, and refuses bad parameters.

Paper geometry (0-4 cm observed, 5 cm bottom, 15 min, 28 h), seed 3, forcing without instrument
noise so recorded forcing is what the ground felt.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pavement_mcmc.synthetic import (
    ALL_EFFECTS,
    EFFECTS,
    NEW_CATALOGUE_EFFECTS,
    OFF_CATALOGUE_EFFECTS,
    SyntheticSpec,
    default_effect,
    simulate,
    temperature_columns,
)

BASE = SyntheticSpec(seed=3, forcing_noise=False, flux_depths_cm=(0.0,))
OBSERVED = temperature_columns(BASE)[:-1]
NEW = NEW_CATALOGUE_EFFECTS + OFF_CATALOGUE_EFFECTS


@pytest.fixture(scope="module")
def base():
    return simulate(BASE)


@pytest.fixture(scope="module")
def runs():
    return {name: simulate(replace(BASE, effects={name: {}})) for name in NEW}


def _hours(truth) -> tuple[np.ndarray, np.ndarray]:
    t_h = truth.t / 3600.0
    return t_h, np.mod(t_h, 24.0)  # time0 is midnight


def _recorded(columns) -> np.ndarray:
    return np.stack([columns[c] for c in OBSERVED], axis=1)


def test_effect_groups():
    assert EFFECTS[:2] == ("two_layer", "sensor_depth") and len(EFFECTS) == 7  # the catalogue's
    assert set(ALL_EFFECTS) == set(EFFECTS) | {
        "surface_layer",
        "evapotranspiration",
        "sensor_lag",
        "shading",
        "buried_source",
        "sensor_sun",
    }
    assert len(ALL_EFFECTS) == len(set(ALL_EFFECTS))


@pytest.mark.parametrize("name", NEW)
def test_new_effect_is_strong_enough_and_keeps_weather_and_noise(name, base, runs):
    """Each effect alone moves some observed sensor by >= 0.5 degC (residuals clearly structured
    at sigma = 0.2), the weather is the same and the noise added is the same draw."""
    columns0, truth0 = base
    columns, truth = runs[name]
    change = np.abs(_recorded(columns) - _recorded(columns0)).max()
    assert change >= 0.5, f"{name}: max change {change:.2f} degC"
    for key in ("time", "T_air", "wind", "rain"):
        np.testing.assert_array_equal(columns[key], columns0[key])
    noise0 = _recorded(columns0) - truth0.T_clean[:, :-1]
    noise = _recorded(columns) - truth.T_clean[:, :-1]
    read = {"sensor_lag": "T_2cm", "sensor_sun": "T_0cm"}  # sensors that do not read T_clean
    untouched = [k for k, c in enumerate(OBSERVED) if read.get(name) != c]
    np.testing.assert_allclose(noise[:, untouched], noise0[:, untouched], atol=1e-12)
    assert list(truth.effects) == [name]
    assert truth.effects[name] == pytest.approx(default_effect(name, BASE.kappa, BASE.C))


def test_surface_layer_damps_and_delays_the_2cm_wave(base, runs):
    _, truth0 = base
    _, truth = runs["surface_layer"]
    t_h, _ = _hours(truth)
    day = t_h < 24.0
    amp0, amp = np.ptp(truth0.T_clean[day, 2]), np.ptp(truth.T_clean[day, 2])
    assert amp < 0.6 * amp0  # measured 15.2 vs 37.0 degC
    peak0, peak = t_h[day][np.argmax(truth0.T_clean[day, 2])], t_h[day][np.argmax(truth.T_clean[day, 2])]
    assert peak >= peak0 + 0.5  # measured 14.00 h vs 13.25 h
    assert truth.effects["surface_layer"]["R_surface"] == pytest.approx(0.015 / 0.06)
    assert truth.soil_top == 0.015 and truth.z[-1] == pytest.approx(0.315)
    # the thatch top (node 0, where the energy balance acts) swings more than the soil below it
    surface = truth.profiles[:, 0]
    assert np.ptp(surface[day]) > 1.5 * np.ptp(truth.T_clean[day, 0])


def test_evapotranspiration_cools_by_day_and_follows_priestley_taylor(base, runs):
    columns0, truth0 = base
    columns, truth = runs["evapotranspiration"]
    _, hod = _hours(truth)
    cooling = truth.T_clean[:, 0] - truth0.T_clean[:, 0]
    midday, night = (hod >= 10) & (hod < 16), hod < 4
    assert cooling[midday].mean() < -5.0  # measured -14.0 degC
    assert cooling[midday].mean() < 5 * cooling[night].mean()  # night: -0.6 (residual)
    # LE = alpha s/(s + gamma) max(R_n - G, 0), with s from Tetens (FAO-56 eq. 13) written out
    # here, R_n what the surface absorbs minus what it emits, G the true flux at the surface
    T = columns["T_air"]
    s = 4098.0 * 0.6108 * np.exp(17.27 * T / (T + 237.3)) / (T + 237.3) ** 2
    expected = s / (s + 0.066) * np.maximum(truth.q_ground - truth.flux["G_0cm"], 0.0)
    assert truth.q_et.max() > 200.0  # measured 368 W m-2
    np.testing.assert_allclose(truth.q_et, expected, atol=1.0)  # G lagged by 5 s: 0.11 measured
    assert truth.effects["evapotranspiration"] == {"et_alpha": 1.0}


def test_shading_cools_only_in_and_after_the_shaded_hours(base, runs):
    columns0, truth0 = base
    columns, truth = runs["shading"]
    _, hod = _hours(truth)
    d = truth.T_clean[:, 0] - truth0.T_clean[:, 0]
    inside = (hod >= 13.5) & (hod <= 16.5)  # half-shaded at the edges (10 min ramps)
    assert d[inside].mean() < -4.0  # measured -8.6 degC
    assert 13.5 <= hod[np.argmin(d)] <= 16.75
    # outside 13.5-18.5 h only yesterday's shade is left: < 20 % of the peak cooling (measured 11 %)
    assert np.abs(d[~((hod >= 13.5) & (hod < 18.5))]).max() < 0.2 * np.abs(d).max()
    # the radiometer is in the sun: recorded q_net = what the ground absorbs, except in the shade
    np.testing.assert_allclose(truth.q_ground[~inside], columns["q_net"][~inside], rtol=1e-12)
    full = (hod > 13.5) & (hod < 16.5)
    assert (truth.q_ground - columns["q_net"])[full].max() < -200.0  # 0.6 x short-wave: 245-400


def test_sensor_lag_delays_one_sensor(base, runs):
    columns0, _ = base
    columns, truth = runs["sensor_lag"]
    assert truth.effects["sensor_lag"] == {"lag_sensor_cm": 2.0, "lag_minutes": 60.0}
    for name in columns:
        if name != "T_2cm":
            np.testing.assert_array_equal(columns[name], columns0[name])
    # noise cancels: x the true reading, y the lagged one; tau dy/dt = x - y
    x, y, t = columns0["T_2cm"], columns["T_2cm"], truth.t
    dydt = np.gradient(y, t)
    slope, offset = np.polyfit(dydt[4:-4], (x - y)[4:-4], 1)
    assert slope == pytest.approx(3600.0, rel=0.05)  # measured 3509 s (central differences)
    assert abs(offset) < 0.05
    t_h, _ = _hours(truth)
    day = t_h < 24
    assert t_h[day][np.argmax(y[day])] > t_h[day][np.argmax(x[day])]


def test_buried_source_warms_most_around_its_depth(base, runs):
    _, truth0 = base
    _, truth = runs["buried_source"]
    assert truth.effects["buried_source"] == {"source_flux": 50.0, "source_depth": 0.015}
    warming = (truth.T_clean - truth0.T_clean).mean(axis=0)  # 0, 1, 2, 3, 4, 5 cm
    assert np.all(warming > 0)
    assert min(warming[1], warming[2]) > max(warming[0], warming[4], warming[5])
    # steady state: the source's power splits between the way up (soil to the surface, then
    # convection and linearised emission) and the way down to the 30 cm Dirichlet bottom
    h_eff = truth0.h_obs.mean() + 4 * 0.95 * 5.670374419e-8 * (truth0.T_clean[:, 0].mean() + 273.15) ** 3
    up, down = 0.015 / BASE.kappa + 1.0 / h_eff, (0.30 - 0.015) / BASE.kappa
    expected = 50.0 * up * down / (up + down)  # 2.65 degC
    assert 0.5 * (warming[1] + warming[2]) == pytest.approx(expected, rel=0.2)  # measured 2.56


def test_field_defaults_follow_the_sensors():
    depths = (2.0, 5.0, 10.0, 20.0)
    assert default_effect("buried_source", 1.2, 2.6e6, depths, 50.0)["source_depth"] == pytest.approx(0.075)
    assert default_effect("sensor_lag", 1.2, 2.6e6, depths, 50.0)["lag_sensor_cm"] == 10.0
    assert default_effect("buried_source", 1.2, 2.6e6, (2.0,), 50.0)["source_depth"] == pytest.approx(0.26)


@pytest.mark.parametrize(
    "effects, message",
    [
        ({"surface_layer": {"R_surface": 0.3}}, "R_surface is derived"),
        ({"surface_layer": {"layer_kappa": 0.0}}, "layer_kappa and layer_C positive"),
        ({"evapotranspiration": {"et_alpha": 2.0}}, "et_alpha must be in"),
        ({"sensor_lag": {"lag_sensor_cm": 2.5}}, "not an observed sensor; valid: 0, 1, 2, 3, 4"),
        ({"sensor_lag": {"lag_minutes": 0.0}}, "lag_minutes must be positive"),
        ({"shading": {"shade_start": 18.0}}, "shade_start < shade_end"),
        ({"shading": {"shade_fraction": 1.5}}, "shade_fraction must be in"),
        ({"buried_source": {"source_depth": 0.06}}, "between the surface and the bottom sensor"),
        ({"shadow": {}}, "valid effects: two_layer, .*buried_source"),
    ],
)
def test_bad_parameters_are_refused(effects, message):
    with pytest.raises(ValueError, match=message):
        simulate(replace(BASE, effects=effects))


def test_lagged_et_closure_refuses_a_factor_near_one():
    """alpha s/(s + gamma) >= 0.95 would make the one-step-lagged closure relax too slowly:
    et_alpha = 1.3 in summer heat (T_air ~ 25 degC: 1.3 x 0.74) is refused, 1.26 in spring is not."""
    with pytest.raises(ValueError, match="lagged closure needs"):
        simulate(replace(BASE, effects={"evapotranspiration": {"et_alpha": 1.3}}))
    spring = replace(BASE, climate="spring", effects={"evapotranspiration": {"et_alpha": 1.26}})
    _, truth = simulate(spring)
    assert truth.q_et.max() > 50.0


def test_twin_effects_are_small_registered_classes():
    """Every hidden effect is a :class:`TwinEffect` found by name (like the catalogue's
    extensions): its defaults pass its own checks, its group is the constant it is listed in,
    and a second class under a taken name is refused."""
    from pavement_mcmc.synthetic import TwinEffect, register_twin_effect, twin_effect
    from pavement_mcmc.synthetic.effects import ALL_EFFECTS, EFFECTS, OFF_CATALOGUE_EFFECTS

    groups = {"catalogue": EFFECTS, "off_catalogue": OFF_CATALOGUE_EFFECTS}
    for name in ALL_EFFECTS:
        effect = twin_effect(name)
        assert isinstance(effect, TwinEffect) and effect.name == name
        assert name in groups.get(effect.group, ("surface_layer", "evapotranspiration"))
        p = effect.defaults(1.2, 1.5e6, (0, 1, 2, 3, 4), 5.0)
        assert effect.bad(p) is None
    assert twin_effect("two_layer").bad({"d_layer": 0.02, "kappa2": -1.0, "C2": 1e6})
    with pytest.raises(ValueError, match="a hidden effect named 'shading' is already registered"):
        register_twin_effect(type("Shade2", (TwinEffect,), {"name": "shading"}))
    with pytest.raises(ValueError, match="valid effects: two_layer"):
        twin_effect("shadow")
