"""What a twin's instruments record from the simulated ground: sensor temperatures (with a
sensor's lag, sun gain and bias), their noise, the forcing's instrument noise and the heat-flux
plates' readings. Used by :func:`~pavement_mcmc.synthetic.simulate.simulate`."""

from __future__ import annotations

import numpy as np

from .processes import first_order_lag


def sensor_temperatures(z: np.ndarray, true_depths: np.ndarray, profiles: np.ndarray) -> np.ndarray:
    """(n_rows, n_sensors) temperatures at the sensors' true depths: linear interpolation between
    the fine nodes ``z`` of each row's profile, degC."""
    return np.array([np.interp(true_depths, z, prof) for prof in profiles])


def sensor_readings(spec, effects: dict, T_clean: np.ndarray, z: np.ndarray,
                    true_depths: np.ndarray, all_profiles: np.ndarray, t_all: np.ndarray,
                    n_spin: int, keep: np.ndarray, sw_rows: np.ndarray) -> np.ndarray:
    """Noise-free readings: ``T_clean`` with a lagging sensor (``sensor_lag``: the lag runs over
    the spin-up rows ``t_all`` / ``all_profiles`` too, then the kept rows) and a sensor warmed by
    the shortwave ``sw_rows`` (``sensor_sun``)."""
    reading = T_clean
    if "sensor_lag" in effects:  # lag over the spin-up rows too, then the kept rows
        p = effects["sensor_lag"]
        k = int(np.argmin(np.abs(np.asarray(spec.depths_cm, float) - p["lag_sensor_cm"])))
        T_k = np.array([np.interp(true_depths[k], z, r) for r in all_profiles])
        reading = T_clean.copy()
        reading[:, k] = first_order_lag(t_all, T_k, p["lag_minutes"] * 60.0)[n_spin:][keep]
    if "sensor_sun" in effects:  # a sensor in the sun reads warm by day
        k = list(spec.depths_cm).index(effects["sensor_sun"]["sun_sensor_cm"])
        reading = reading.copy()
        reading[:, k] += effects["sensor_sun"]["sun_gain"] * sw_rows / 1000.0
    return reading


def recorded_temperatures(spec, effects: dict, reading: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """Readings plus ``spec.sigma`` x the first ``noise`` columns, then each observed sensor's
    bias (``sensor_bias``)."""
    n = reading.shape[1]
    recorded = reading + spec.sigma * noise[:, :n]
    if "sensor_bias" in effects:
        recorded[:, : len(spec.depths_cm)] += np.array(list(effects["sensor_bias"].values()))
    return recorded


def recorded_forcing(spec, T_air: np.ndarray, q_net: np.ndarray, noise: np.ndarray):
    """``(T_air, q_net)`` as recorded: with ``spec.forcing_noise``, 0.05 degC on T_air and
    1 % + 2 W m-2 on q_net from the last three ``noise`` columns."""
    if spec.forcing_noise:
        T_air = T_air + 0.05 * noise[:, -3]
        q_net = q_net * (1.0 + 0.01 * noise[:, -2]) + 2.0 * noise[:, -1]
    return T_air, q_net


def plate_columns(spec, names: list[str], flux: np.ndarray, rng: np.random.Generator,
                  n_rows: int, keep: np.ndarray) -> tuple[dict, dict]:
    """``(readings, true flux)`` by plate column name: the true conductive flux ``flux[:, j]``
    times the calibration factor and ``1 + plate_rel_noise N1``, plus ``plate_abs_noise N2``
    (drawn for every regular row from ``rng``, so dropped rows leave the others unchanged)."""
    plate_noise = rng.standard_normal((n_rows, 2 * len(names)))[keep]
    readings, flux_true = {}, {}
    for j, name in enumerate(names):
        flux_true[name] = flux[:, j]
        gain = spec.plate_factor * (1.0 + spec.plate_rel_noise * plate_noise[:, 2 * j])
        readings[name] = gain * flux[:, j] + spec.plate_abs_noise * plate_noise[:, 2 * j + 1]
    return readings, flux_true


def tower_columns(closure: float, H: np.ndarray, LE: np.ndarray,
                  rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A flux tower's ``H`` and ``LE`` (W m-2, leaving the surface) from the true fluxes: each
    ``closure`` x true x (1 + 0.1 N1) + 5 N2 (see ``SyntheticSpec.tower``)."""
    out = {}
    for name, flux in (("H", H), ("LE", LE)):
        n1, n2 = rng.standard_normal((2, flux.size))
        out[name] = closure * np.asarray(flux, float) * (1.0 + 0.1 * n1) + 5.0 * n2
    return out


def ir_column(spec, z: np.ndarray, profiles: np.ndarray, soil_top: float,
              rng: np.random.Generator) -> np.ndarray:
    """An infrared thermometer's reading (n_rows,), degC, looking down into a porous layer
    (see ``SyntheticSpec.ir_view``): the share of its view stopped between depths ``s`` and
    ``s + ds`` of the layer is ``lam exp(-lam s) ds``, with ``lam`` such that ``spec.ir_view``
    is stopped in the layer and the rest reaches the soil surface at ``soil_top``; radiances
    (T^4, K) are averaged, + ``spec.ir_offset`` + ``spec.ir_noise`` N. Without a layer, or
    with a view of 1, it reads the column's top. Not the inversion's form (a linear share of
    one lumped skin node and the soil surface)."""
    f = float(spec.ir_view)
    if soil_top > 0 and f < 1:
        lam = -np.log(1.0 - f) / soil_top
        zz = np.concatenate([z[z < soil_top], [soil_top]])
        T = np.array([np.interp(zz, z, prof) for prof in profiles]) + 273.15
        w = np.exp(-lam * zz[:-1]) - np.exp(-lam * zz[1:])  # stopped in each cell
        R = (0.5 * (T[:, :-1] ** 4 + T[:, 1:] ** 4)) @ w + (1.0 - f) * T[:, -1] ** 4
        reading = R ** 0.25 - 273.15
    else:
        reading = profiles[:, 0]
    return reading + spec.ir_offset + spec.ir_noise * rng.standard_normal(reading.size)
