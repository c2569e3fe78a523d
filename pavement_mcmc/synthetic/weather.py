"""A plausible synthetic weather generator: clear-sky-ish mid-latitude June days over asphalt
("summer", the default) or early-April days over grass ("spring", like the Goettingen record).

Every series is a smooth function of time: a deterministic diurnal shape plus smooth random
perturbations (cubic splines through hourly N(0, 1) knots), so that sampling every 15 min
and interpolating linearly loses almost nothing. Times are seconds from the start of the
recorded window (negative during the spin-up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from .column import KELVIN, STEFAN_BOLTZMANN

HOUR = 3600.0


@dataclass(frozen=True)
class Weather:
    """Smooth weather over an interval, evaluated by calling its methods at times in s.

    Attributes
    ----------
    t_start, t_end : covered interval, s from the window start.
    rain_events : ((start_h, duration_h, total_mm), ...) showers inside the window.
    params : the shape parameters (see :func:`make_weather`).
    """

    t_start: float
    t_end: float
    rain_events: tuple
    params: dict
    _noise: tuple  # CubicSplines of unit-variance smooth noise, one per series

    def _hour_of_day(self, t: np.ndarray) -> np.ndarray:
        return np.mod(np.asarray(t, float) / HOUR + self.params["start_hour"], 24.0)

    def raining(self, t: np.ndarray) -> np.ndarray:
        """Fraction of cloud darkening from showers, 0..1 (smooth ramps of 30 min)."""
        t = np.asarray(t, float)
        out = np.zeros_like(t)
        for start, dur, _ in self.rain_events:
            a, b = start * HOUR, (start + dur) * HOUR
            ramp = 0.5 * HOUR
            up = np.clip((t - (a - ramp)) / ramp, 0, 1)
            down = np.clip(((b + ramp) - t) / ramp, 0, 1)
            out = np.maximum(out, np.minimum(up, down))
        return out

    def air_temperature(self, t: np.ndarray) -> np.ndarray:
        """Air temperature, degC: asymmetric diurnal cycle (min ~04:30, max ~15:00 UTC)."""
        p = self.params
        hod = self._hour_of_day(t)
        tmin, tmax = p["t_min_hour"], p["t_max_hour"]
        rising = (hod >= tmin) & (hod < tmax)
        phase = np.where(
            rising,
            np.pi * (hod - tmin) / (tmax - tmin),
            np.pi + np.pi * np.mod(hod - tmax, 24.0) / (24.0 - (tmax - tmin)),
        )
        shape = -np.cos(phase)  # -1 at the minimum, +1 at the maximum
        noise = self._noise[0](t)
        return p["T_mean"] + p["T_amp"] * shape + p["T_noise"] * noise - 1.5 * self.raining(t)

    def cloudiness(self, t: np.ndarray) -> np.ndarray:
        """Fraction of clear-sky short-wave that reaches the ground, 0..1."""
        c = 1.0 - self.params["cloud"] * self._noise[1](t) ** 2
        return np.clip(c * (1.0 - 0.75 * self.raining(t)), 0.05, 1.0)

    def shortwave_absorbed(self, t: np.ndarray) -> np.ndarray:
        """Short-wave radiation absorbed by the surface, W m-2 (zero at night)."""
        p = self.params
        hod = self._hour_of_day(t)
        s = np.sin(np.pi * (hod - p["sunrise_hour"]) / p["day_length_h"])
        clear = p["S_max"] * np.clip(s, 0.0, None) ** 1.5
        return (1.0 - p["albedo"]) * clear * self.cloudiness(t)

    def longwave_down(self, t: np.ndarray) -> np.ndarray:
        """Down-welling long-wave radiation, W m-2: eps_sky sigma (T_air + 273.15)^4."""
        p = self.params
        eps = p["eps_sky"] + 0.02 * self._noise[2](t) + 0.15 * (1.0 - self.cloudiness(t))
        return np.clip(eps, 0.6, 0.98) * STEFAN_BOLTZMANN * (self.air_temperature(t) + KELVIN) ** 4

    def wind(self, t: np.ndarray) -> np.ndarray:
        """Wind speed, m s-1: calm nights, breezier afternoons, smooth gusts of ~1 h."""
        p = self.params
        hod = self._hour_of_day(t)
        diurnal = 0.5 - 0.5 * np.cos(2 * np.pi * (hod - p["wind_calm_hour"]) / 24.0)
        v = p["wind_night"] + p["wind_amp"] * diurnal + p["wind_noise"] * self._noise[3](t)
        return np.clip(v, 0.2, None)


CLIMATES = {
    "summer": {
        "T_mean": 18.0,
        "T_amp": 6.5,
        "T_noise": 0.4,
        "t_min_hour": 4.5,
        "t_max_hour": 15.0,
        "S_max": 880.0,
        "albedo": 0.1,
        "sunrise_hour": 4.1,
        "day_length_h": 16.0,
        "cloud": 0.06,
        "eps_sky": 0.76,
        "wind_night": 1.2,
        "wind_amp": 1.6,
        "wind_noise": 0.45,
        "wind_calm_hour": 3.5,
        "T_deep_offset": 8.0,
    },
    "spring": {
        "T_mean": 8.0,
        "T_amp": 6.0,
        "T_noise": 0.5,
        "t_min_hour": 5.0,
        "t_max_hour": 14.0,
        "S_max": 720.0,
        "albedo": 0.22,
        "sunrise_hour": 5.2,
        "day_length_h": 12.8,
        "cloud": 0.15,
        "eps_sky": 0.72,
        "wind_night": 0.8,
        "wind_amp": 1.6,
        "wind_noise": 0.4,
        "wind_calm_hour": 3.5,
        "T_deep_offset": -0.5,
    },
}
"""Deterministic shape parameters of each climate (times are UTC hours of day; S_max W m-2 is
the clear-sky global radiation at noon; T_deep_offset degC is the default deep temperature
minus the mean air temperature: a sun-heated pavement in summer, a soil still cool from winter
in spring). "spring" stands for early April at ~51 N over grass (sunrise ~05 UTC, 12.8 h of
day, noon sun ~43 degrees high)."""


def make_weather(
    rng: np.random.Generator,
    t_start: float,
    t_end: float,
    rain_events: tuple = (),
    start_hour: float = 0.0,
    climate: str = "summer",
) -> Weather:
    """Draw a weather realisation.

    Parameters
    ----------
    rng : random generator (the only source of randomness; the same draws for every climate).
    t_start, t_end : interval to cover, s from the window start (spin-up included).
    rain_events : ``((start_h, duration_h, total_mm), ...)`` showers, hours from the window start.
    start_hour : UTC hour of day at ``t == 0``.
    climate : a key of :data:`CLIMATES`.

    Returns
    -------
    Weather. Typical values, summer: T_air 11-25 degC, absorbed short-wave up to ~800 W m-2,
    long-wave 290-360 W m-2, wind 1-4 m s-1; spring: T_air 1-15 degC, absorbed short-wave up to
    ~560 W m-2, long-wave 250-310 W m-2, wind 0.5-3.5 m s-1.
    """
    if climate not in CLIMATES:
        raise ValueError(f"unknown climate {climate!r}; valid: {', '.join(CLIMATES)}")
    base = CLIMATES[climate]
    params = {"start_hour": start_hour, **base}
    params["T_mean"] = base["T_mean"] + rng.normal(0.0, 1.0)
    params["T_amp"] = base["T_amp"] + rng.normal(0.0, 0.5)
    knots = np.arange(np.floor(t_start / HOUR) - 2, np.ceil(t_end / HOUR) + 3) * HOUR
    noise = tuple(CubicSpline(knots, rng.standard_normal(knots.size)) for _ in range(4))
    return Weather(float(t_start), float(t_end), tuple(rain_events), params, noise)
