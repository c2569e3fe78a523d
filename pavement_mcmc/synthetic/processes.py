"""Pure, vectorised kernels of the twin simulator's surface and sensor processes.

Rain and its latent sink (``evaporation``), the Priestley-Taylor factor
(``evapotranspiration``), a daily shadow (``shading``) and a first-order sensor lag
(``sensor_lag``). Times are in s from the window start, hours of day on the spec's time0 clock.
"""

from __future__ import annotations

import numpy as np

from .weather import HOUR

PSYCHROMETRIC = 0.066
"""Psychrometric constant gamma, kPa K-1 (sea level)."""


def rain_per_row(events: tuple, t_rows: np.ndarray, hours: float) -> np.ndarray:
    """Rain (mm, 0.1 mm resolution) of each regular row: what fell in (t_{k-1}, t_k]."""
    cumulative = np.zeros(t_rows.size)
    for start, duration, total in events:
        if not (0 <= start and start + duration <= hours and duration > 0 and total >= 0):
            raise ValueError(f"rain event {(start, duration, total)} must lie inside the window")
        a, b = start * HOUR, (start + duration) * HOUR
        cumulative += total * np.clip((t_rows - a) / (b - a), 0.0, 1.0)
    return np.diff(np.round(cumulative, 1), prepend=0.0)


def rain_latent_flux(t_rows: np.ndarray, rain: np.ndarray, A: float, tau_h: float) -> np.ndarray:
    """A sum_{t_k <= t} r_k exp(-(t - t_k)/tau) at the row times, W m-2."""
    tau = tau_h * HOUR
    q = np.zeros(t_rows.size)
    for k in np.flatnonzero(rain):
        q[k:] += A * rain[k] * np.exp(-(t_rows[k:] - t_rows[k]) / tau)
    return q


def saturation_pressure(T: np.ndarray) -> np.ndarray:
    """Saturation vapour pressure ``e_s(T) = 0.6108 exp(17.27 T / (T + 237.3))`` kPa, T in degC
    (Tetens, FAO-56 eq. 11)."""
    T = np.asarray(T, float)
    return 0.6108 * np.exp(17.27 * T / (T + 237.3))


def saturation_slope(T: np.ndarray) -> np.ndarray:
    """Slope s of the saturation vapour pressure curve (Tetens), kPa K-1.

    ``e_s(T) = 0.6108 exp(17.27 T / (T + 237.3))`` kPa, ``s = 4098 e_s / (T + 237.3)^2``,
    T in degC (FAO-56, eq. 13). About 0.145 kPa K-1 at 20 degC.
    """
    T = np.asarray(T, float)
    return 4098.0 * saturation_pressure(T) / (T + 237.3) ** 2


def priestley_taylor_factor(T_air: np.ndarray, alpha: float) -> np.ndarray:
    """``alpha s / (s + gamma)``: the fraction of the available energy R_n - G that leaves as
    latent heat (Priestley & Taylor 1972), dimensionless; s from :func:`saturation_slope`."""
    s = saturation_slope(T_air)
    return alpha * s / (s + PSYCHROMETRIC)


def penman_monteith_terms(T_air: np.ndarray, h: np.ndarray, vapour_kPa: float,
                          r_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(factor, vapour flux)`` of a Penman-Monteith latent heat
    ``LE = factor x A + vapour flux``, A the available energy (W m-2): with D = max(e_s(T_air)
    - vapour_kPa, 0) the vapour pressure deficit (kPa), h the convective transfer coefficient
    (W m-2 K-1, rho c_p / r_a), r_s the surface resistance (s m-1) and rho c_p = 1200 J m-3 K-1,
    factor = s / den and vapour flux = h D / den, den = s + gamma (1 + r_s h / rho c_p)."""
    T = np.asarray(T_air, float)
    e_s = saturation_pressure(T)
    s = saturation_slope(T)
    den = s + PSYCHROMETRIC * (1.0 + r_s * np.asarray(h, float) / 1200.0)
    return s / den, np.asarray(h, float) * np.maximum(e_s - vapour_kPa, 0.0) / den


def relative_humidity(T_air: np.ndarray, vapour_kPa: float) -> np.ndarray:
    """RH (%) of air at ``T_air`` (degC) holding ``vapour_kPa`` of water vapour, at most 100."""
    return np.minimum(100.0 * vapour_kPa / saturation_pressure(T_air), 100.0)


SHADE_EDGE_MINUTES = 10.0
"""Time a shadow edge takes to cross the plot: the shade ramps in and out linearly over this
time, centred on the given clock hours (a step would make a row at the edge sample the
sqrt(t) start of the surface's response, so its value would depend on the time step)."""


def shade_multiplier(
    t: np.ndarray, start_hour: float, shade_start: float, shade_end: float, fraction: float
) -> np.ndarray:
    """Factor on the absorbed short-wave: ``1 - fraction`` while the clock hour is in
    ``[shade_start, shade_end]``, else 1, with linear ramps of :data:`SHADE_EDGE_MINUTES`
    centred on both hours.

    Parameters
    ----------
    t : times, s from the window start.
    start_hour : clock hour of day at ``t == 0``.
    shade_start, shade_end : clock hours bounding the daily shadow (0 <= start < end <= 24).
    fraction : fraction of the short-wave the shadow removes.
    """
    hod = np.mod(np.asarray(t, float) / HOUR + start_hour, 24.0)
    half = 0.5 * SHADE_EDGE_MINUTES / 60.0
    shade = np.zeros_like(hod)
    for day in (-24.0, 0.0, 24.0):  # a shadow reaching past midnight on either side
        a, b = shade_start + day, shade_end + day
        rise = np.clip((hod - (a - half)) / (2 * half), 0.0, 1.0)
        fall = np.clip(((b + half) - hod) / (2 * half), 0.0, 1.0)
        shade = np.maximum(shade, np.minimum(rise, fall))
    return 1.0 - fraction * shade


def first_order_lag(t: np.ndarray, x: np.ndarray, tau: float) -> np.ndarray:
    """Reading y of a first-order sensor, ``tau dy/dt = x - y``, with ``y(t_0) = x(t_0)``.

    ``x`` is taken linear between the samples, for which the update is exact::

        y_k = x_k + (y_{k-1} - x_{k-1}) e + (x_k - x_{k-1}) tau / dt (e - 1),   e = exp(-dt / tau)

    Parameters
    ----------
    t : (n,) increasing times, s.
    x : (n,) true signal.
    tau : time constant, s (> 0).

    Returns
    -------
    (n,) lagged signal.
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, x.size):
        dt = t[k] - t[k - 1]
        e = np.exp(-dt / tau)
        y[k] = x[k] + (y[k - 1] - x[k - 1]) * e + (x[k] - x[k - 1]) * tau / dt * (e - 1.0)
    return y
