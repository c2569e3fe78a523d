"""A twin's time levels and the forcing its ground feels: weather sampled at every solver level
(smooth or linear between rows), h(t), the absorbed and recorded radiation, and the sinks
(evaporation after rain, Priestley-Taylor evapotranspiration). Used by
:func:`~pavement_mcmc.synthetic.simulate.simulate`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator

from .column import KELVIN, STEFAN_BOLTZMANN
from .processes import priestley_taylor_factor, rain_latent_flux, shade_multiplier
from .weather import HOUR

PT_FACTOR_MAX = 0.95
"""Largest Priestley-Taylor factor alpha s/(s + gamma) the lagged ET closure accepts (it relaxes
with this ratio per solver step; at 1 it would not converge)."""


@dataclass(frozen=True)
class Clock:
    """Time levels: rows every ``step`` s, ``substeps`` solver steps of ``dt`` s per row, the
    spin-up ``n_spin`` whole rows before the ``n_rows`` of the window (t = 0 at its first row)."""

    step: float
    substeps: int
    dt: float
    n_rows: int
    n_spin: int
    t_levels: np.ndarray
    t_rows_all: np.ndarray

    @classmethod
    def of(cls, spec, dt_target: float) -> Clock:
        step = spec.step_minutes * 60.0
        substeps = int(np.ceil(step / dt_target - 1e-9))
        dt = step / substeps
        n_rows = int(round(spec.hours * HOUR / step)) + 1
        n_spin = int(round(spec.spinup_hours * HOUR / step))
        t_levels = (np.arange((n_spin + n_rows - 1) * substeps + 1) - n_spin * substeps) * dt
        return cls(step=step, substeps=substeps, dt=dt, n_rows=n_rows, n_spin=n_spin,
                   t_levels=t_levels, t_rows_all=(np.arange(n_rows)) * step)


@dataclass(frozen=True)
class Forcing:
    """The forcing at every time level: air temperature, wind, radiometer shortwave and longwave,
    h, the radiation the ground absorbs (``q_abs``) and the radiometer's open-sky one
    (``q_open``), the emissivity the solver applies, and the radiation factor ``f``."""

    T_air: np.ndarray
    wind: np.ndarray
    sw: np.ndarray
    h: np.ndarray
    q_abs: np.ndarray
    q_open: np.ndarray
    e_rad: float
    f: float


def forcing_at_levels(spec, effects: dict, weather, clock: Clock, start_hour: float) -> Forcing:
    t_levels = clock.t_levels
    if spec.forcing == "smooth":

        def at_levels(fun):
            return fun(t_levels)
    elif spec.forcing == "linear":  # sampled at every row (spin-up too), linear in between
        t_knots = t_levels[::clock.substeps]

        def at_levels(fun):
            return np.interp(t_levels, t_knots, fun(t_knots))
    else:
        raise ValueError(f"forcing={spec.forcing!r}; valid: 'smooth', 'linear'")
    T_air = at_levels(weather.air_temperature)
    wind = at_levels(weather.wind)
    sw, lw = at_levels(weather.shortwave_absorbed), at_levels(weather.longwave_down)
    if "wind_convection" in effects:
        h = effects["wind_convection"]["h_a"] + effects["wind_convection"]["h_b"] * wind
    else:
        knots_t = np.linspace(0.0, spec.hours * HOUR, len(spec.h_knots))
        spline = PchipInterpolator(knots_t, spec.h_knots)
        h = at_levels(lambda t: spline(np.clip(t, 0.0, knots_t[-1])))  # h(0) in the spin-up
    f = effects.get("radiation_factor", {}).get("rad_factor", 1.0)
    sw_ground = sw  # what reaches the ground; the radiometer sees `sw`
    if "shading" in effects:
        p = effects["shading"]
        shade = shade_multiplier(t_levels, start_hour, p["shade_start"], p["shade_end"], p["shade_fraction"])
        sw_ground = sw * shade
    eps_sigma = spec.emissivity * STEFAN_BOLTZMANN
    if spec.emission:
        q_abs, q_open, e_rad = f * (sw_ground + lw), f * (sw + lw), f * spec.emissivity
    else:
        q_abs = f * (sw_ground + lw - eps_sigma * (T_air + KELVIN) ** 4)
        q_open, e_rad = f * (sw + lw - eps_sigma * (T_air + KELVIN) ** 4), 0.0
    return Forcing(T_air=T_air, wind=wind, sw=sw, h=h, q_abs=q_abs, q_open=q_open, e_rad=e_rad,
                    f=f)


def ground_sinks(effects: dict, t_rows, rain, t_levels, T_air):
    """``(q_evap at the rows, q_sink at every level, Priestley-Taylor factor or None)``: the
    ``evaporation`` effect's latent flux after rain and the ``evapotranspiration`` one's factor."""
    q_evap_rows = np.zeros(t_rows.size)
    if "evaporation" in effects:
        if not rain.any():
            raise ValueError("the evaporation effect needs rain inside the recorded window")
        p = effects["evaporation"]
        q_evap_rows = rain_latent_flux(t_rows, rain, p["evap_A"], p["evap_tau"])
    q_sink = np.interp(t_levels, t_rows, q_evap_rows, left=0.0)
    pt_factor = None
    if "evapotranspiration" in effects:
        pt_factor = priestley_taylor_factor(T_air, effects["evapotranspiration"]["et_alpha"])
        if pt_factor.max() >= PT_FACTOR_MAX:
            raise ValueError(
                f"effect 'evapotranspiration': et_alpha s/(s + gamma) reaches {pt_factor.max():.3f} "
                f"at T_air = {T_air.max():.1f} degC; the lagged closure needs < {PT_FACTOR_MAX}"
            )
    return q_evap_rows, q_sink, pt_factor
