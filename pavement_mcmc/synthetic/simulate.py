"""Twin datasets: weather -> deep fine-grid ground column -> sensors with noise and hidden effects."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timedelta

import numpy as np
from scipy.interpolate import PchipInterpolator

from .column import KELVIN, STEFAN_BOLTZMANN, integrate, layered_column, stretched_nodes
from .effects import DEFAULT_RAIN, resolve_effects
from .weather import HOUR, make_weather

PAPER_H_KNOTS = (16.67, 6.43, 10.29, 14.33, 12.92)
"""The paper's Case C h estimates (W m-2 K-1), placed evenly over the window (0, 7, ... 28 h)."""


@dataclass(frozen=True)
class SyntheticSpec:
    """Everything that defines one twin dataset.

    Attributes
    ----------
    kappa : conductivity (top layer), W m-1 K-1.
    C : volumetric heat capacity (top layer), J m-3 K-1.
    sigma : sd of the Gaussian noise on every temperature column (bottom sensor too), degC.
    hours : length of the recorded window, h.
    step_minutes : sampling step, min (rows are on this grid; see ``drop_fraction``).
    depths_cm : nominal depths of the observed sensors, cm (also their CSV column names).
    bottom_cm : depth of the bottom sensor the inversion uses as Dirichlet boundary, cm.
    effects : hidden effect name -> parameter overrides ({} or None: realistic defaults);
        see :mod:`pavement_mcmc.synthetic.effects`.
    seed : seed of every random draw (weather, noise, dropped rows use independent streams,
        so switching an effect on leaves the weather and noise unchanged).
    emission : True: the surface emits eps sigma T_s^4 and ``q_net`` records
        SW + LW_down - eps sigma T_s^4. False (test mode): the net radiation is prescribed,
        SW + LW_down - eps sigma T_air^4, so the recorded q_net is exactly what the ground gets.
    emissivity : surface emissivity eps.
    rain : showers ``((start_h, duration_h, total_mm), ...)`` inside the window; None means
        :data:`DEFAULT_RAIN` if ``evaporation`` is on, else no rain.
    h_knots : true h (W m-2 K-1) at evenly spaced times over the window, joined by a PCHIP
        spline (ignored under ``wind_convection``).
    drop_fraction : probability that an interior row is missing (irregular sampling).
    forcing_noise : add instrument noise to T_air (0.05 degC) and q_net (1 % + 2 W m-2).
    forcing : "smooth": the weather and h(t) the ground feels are smooth functions of time
        that the rows sample (realistic). "linear": they are linear in time between rows (and
        between row-spaced times in the spin-up), like the inversion's interpolation of its
        inputs; only the emission -eps sigma T_s^4 and the 5 cm temperature then differ from
        piecewise-linear functions.
    spinup_hours : simulated time before the window (same weather generator), h.
    column_cm : depth of the simulated column, cm (fixed temperature ``T_deep`` there).
    T_deep : deep temperature and uniform initial temperature at the start of the spin-up,
        degC; None: mean air temperature + 8 degC.
    dz_mm : cell size in the resolved zone (down to 2 cm below the deepest sensor), mm.
    dt_s : target time step, s (rounded down to divide the sampling step).
    time0 : ISO 8601 UTC time of the first row.
    """

    kappa: float = 1.31
    C: float = 0.99e6
    sigma: float = 0.2
    hours: float = 28.0
    step_minutes: float = 15.0
    depths_cm: tuple = (0.0, 1.0, 2.0, 3.0, 4.0)
    bottom_cm: float = 5.0
    effects: dict = field(default_factory=dict)
    seed: int = 0
    emission: bool = True
    emissivity: float = 0.95
    rain: tuple | None = None
    h_knots: tuple = PAPER_H_KNOTS
    drop_fraction: float = 0.0
    forcing_noise: bool = True
    forcing: str = "smooth"
    spinup_hours: float = 48.0
    column_cm: float = 30.0
    T_deep: float | None = None
    dz_mm: float = 0.25
    dt_s: float = 5.0
    time0: str = "2004-06-06T00:00:00Z"


@dataclass(frozen=True)
class Truth:
    """The answer a twin dataset was generated with.

    Attributes
    ----------
    kappa, C : top-layer conductivity (W m-1 K-1) and heat capacity (J m-3 K-1).
    sigma : temperature noise sd, degC.
    h_obs : (n_obs,) true h at each row's time, W m-2 K-1.
    effects : hidden effect name -> complete parameter dict (empty: none).
    t : (n_obs,) row times, s from the first row.
    T_clean : (n_obs, n_columns) noise-free, bias-free temperatures at the sensors' true depths,
        degC, in the order of the ``T_<d>cm`` columns (observed sensors, then the bottom one).
    z : (n_nodes,) depths of the simulator's nodes, m.
    T_initial : (n_nodes,) true temperature profile at t = 0 (after spin-up), degC.
    q_ground : (n_obs,) net radiation actually absorbed by the ground at each row, W m-2.
    q_evap : (n_obs,) latent heat flux out of the ground at each row, W m-2.
    noise_rms : RMS of the noise actually added to the observed sensors, degC.
    seed : the spec's seed.
    """

    kappa: float
    C: float
    sigma: float
    h_obs: np.ndarray
    effects: dict
    t: np.ndarray
    T_clean: np.ndarray
    z: np.ndarray
    T_initial: np.ndarray
    q_ground: np.ndarray
    q_evap: np.ndarray
    noise_rms: float = 0.0
    seed: int = 0


def temperature_columns(spec: SyntheticSpec) -> list[str]:
    """CSV names of the temperature columns: observed sensors, then the bottom one."""
    return [f"T_{d:g}cm" for d in (*spec.depths_cm, spec.bottom_cm)]


def _check(spec: SyntheticSpec) -> tuple[np.ndarray, float]:
    depths = np.asarray(spec.depths_cm, float) / 100.0
    bottom = spec.bottom_cm / 100.0
    if depths.size == 0 or np.any(np.diff(depths) <= 0) or depths[0] < 0 or depths[-1] >= bottom:
        raise ValueError(f"depths_cm={spec.depths_cm} must increase from >= 0 to < bottom_cm")
    if not bottom + 0.05 <= spec.column_cm / 100.0:
        raise ValueError("column_cm must reach at least 5 cm below bottom_cm")
    if spec.kappa <= 0 or spec.C <= 0 or spec.sigma < 0:
        raise ValueError("kappa and C must be positive and sigma >= 0")
    if not 0 <= spec.drop_fraction < 1:
        raise ValueError("drop_fraction must be in [0, 1)")
    if spec.hours <= 0 or spec.step_minutes <= 0 or spec.spinup_hours < 0:
        raise ValueError("hours and step_minutes must be positive, spinup_hours >= 0")
    return depths, bottom


def _rain_per_row(events: tuple, t_rows: np.ndarray, hours: float) -> np.ndarray:
    """Rain (mm, 0.1 mm resolution) of each regular row: what fell in (t_{k-1}, t_k]."""
    cumulative = np.zeros(t_rows.size)
    for start, duration, total in events:
        if not (0 <= start and start + duration <= hours and duration > 0 and total >= 0):
            raise ValueError(f"rain event {(start, duration, total)} must lie inside the window")
        a, b = start * HOUR, (start + duration) * HOUR
        cumulative += total * np.clip((t_rows - a) / (b - a), 0.0, 1.0)
    return np.diff(np.round(cumulative, 1), prepend=0.0)


def _latent_flux(t_rows: np.ndarray, rain: np.ndarray, A: float, tau_h: float) -> np.ndarray:
    """A sum_{t_k <= t} r_k exp(-(t - t_k)/tau) at the row times, W m-2."""
    tau = tau_h * HOUR
    q = np.zeros(t_rows.size)
    for k in np.flatnonzero(rain):
        q[k:] += A * rain[k] * np.exp(-(t_rows[k:] - t_rows[k]) / tau)
    return q


def _iso_times(time0: str, t: np.ndarray) -> np.ndarray:
    start = datetime.fromisoformat(time0.replace("Z", "+00:00"))
    stamps = [(start + timedelta(seconds=float(s))).strftime("%Y-%m-%dT%H:%M:%SZ") for s in t]
    return np.asarray(stamps)


def simulate(spec: SyntheticSpec) -> tuple[dict[str, np.ndarray], Truth]:
    """Generate one twin dataset.

    Parameters
    ----------
    spec : what to generate.

    Returns
    -------
    columns : the CSV contract's columns, unrounded: ``time`` (ISO 8601 strings), ``T_air``
        (degC), ``q_net`` (W m-2), ``wind`` (m s-1), ``rain`` (mm per row), ``T_<d>cm`` (degC).
    truth : the true parameters, h(t), effects and noise-free temperatures.
    """
    depths, bottom = _check(spec)
    effects = resolve_effects(spec.effects or {}, spec.kappa, spec.C, spec.depths_cm, spec.bottom_cm)
    seq = np.random.SeedSequence(spec.seed)
    rng_weather, rng_noise, rng_rows = (np.random.default_rng(s) for s in seq.spawn(3))

    # time levels: rows every `step`, solver steps of dt dividing it, spin-up whole rows
    step = spec.step_minutes * 60.0
    substeps = int(np.ceil(step / spec.dt_s - 1e-9))
    dt = step / substeps
    n_rows = int(round(spec.hours * HOUR / step)) + 1
    n_spin = int(round(spec.spinup_hours * HOUR / step))
    t_levels = (np.arange((n_spin + n_rows - 1) * substeps + 1) - n_spin * substeps) * dt
    t_rows_all = (np.arange(n_rows)) * step

    rain_events = spec.rain if spec.rain is not None else (DEFAULT_RAIN if "evaporation" in effects else ())
    start_hour = datetime.fromisoformat(spec.time0.replace("Z", "+00:00"))
    start_hour = start_hour.hour + start_hour.minute / 60.0 + start_hour.second / 3600.0
    weather = make_weather(rng_weather, t_levels[0], t_levels[-1], tuple(rain_events), start_hour=start_hour)

    # rows kept (irregular sampling) and their rain, accumulated over dropped rows
    keep = rng_rows.random(n_rows) >= spec.drop_fraction
    keep[0] = keep[-1] = True
    rain_all = _rain_per_row(tuple(rain_events), t_rows_all, spec.hours)
    rain = np.diff(np.cumsum(rain_all)[keep], prepend=0.0)
    rain = np.round(rain, 1)
    t_rows = t_rows_all[keep]

    # forcing at every time level
    if spec.forcing == "smooth":

        def at_levels(fun):
            return fun(t_levels)
    elif spec.forcing == "linear":  # sampled at every row (spin-up too), linear in between
        t_knots = t_levels[::substeps]

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
    eps_sigma = spec.emissivity * STEFAN_BOLTZMANN
    if spec.emission:
        q_abs, e_rad = f * (sw + lw), f * spec.emissivity
    else:
        q_abs, e_rad = f * (sw + lw - eps_sigma * (T_air + KELVIN) ** 4), 0.0
    q_evap_rows = np.zeros(t_rows.size)
    if "evaporation" in effects:
        if not rain.any():
            raise ValueError("the evaporation effect needs rain inside the recorded window")
        p = effects["evaporation"]
        q_evap_rows = _latent_flux(t_rows, rain, p["evap_A"], p["evap_tau"])
    q_sink = np.interp(t_levels, t_rows, q_evap_rows, left=0.0)

    # the column
    kap, Cs, interfaces = [spec.kappa], [spec.C], []
    if "two_layer" in effects:
        p = effects["two_layer"]
        kap, Cs, interfaces = [spec.kappa, p["kappa2"]], [spec.C, p["C2"]], [p["d_layer"]]
    offsets = np.array(list(effects.get("sensor_depth", {}).values()) or np.zeros(depths.size))
    true_depths = np.append(depths + offsets, bottom)
    fine = max(true_depths.max(), *(interfaces or [0.0])) + 0.02
    z = stretched_nodes(fine, spec.column_cm / 100.0, spec.dz_mm / 1000.0)
    column = layered_column(z, np.asarray(interfaces), np.asarray(kap), np.asarray(Cs))
    T_deep = weather.params["T_mean"] + 8.0 if spec.T_deep is None else spec.T_deep
    profiles = integrate(
        column,
        np.full(z.size, T_deep),
        dt,
        T_air,
        h,
        q_abs,
        q_sink,
        np.full(t_levels.size, T_deep),
        emissivity=e_rad,
        beta=effects.get("conductivity_temperature", {}).get("kappa_beta", 0.0),
        record_every=substeps,
    )[n_spin:][keep]

    # sensors: linear interpolation between fine nodes at the true depths
    T_clean = np.array([np.interp(true_depths, z, prof) for prof in profiles])
    row_levels = (np.arange(n_rows) + n_spin) * substeps
    lv = row_levels[keep]
    q_ground = q_abs[lv] - e_rad * STEFAN_BOLTZMANN * (profiles[:, 0] + KELVIN) ** 4
    q_rec = q_ground / f
    T_air_rec = T_air[lv].copy()

    # noise: drawn for every regular row, so dropping rows or adding effects leaves it unchanged
    noise = rng_noise.standard_normal((n_rows, true_depths.size + 3))[keep]
    recorded = T_clean + spec.sigma * noise[:, : true_depths.size]
    if "sensor_bias" in effects:
        recorded[:, : depths.size] += np.array(list(effects["sensor_bias"].values()))
    if spec.forcing_noise:
        T_air_rec += 0.05 * noise[:, -3]
        q_rec = q_rec * (1.0 + 0.01 * noise[:, -2]) + 2.0 * noise[:, -1]

    columns: dict[str, np.ndarray] = {
        "time": _iso_times(spec.time0, t_rows),
        "T_air": T_air_rec,
        "q_net": q_rec,
        "wind": np.round(wind[lv], 2),
        "rain": rain,
    }
    for name, values in zip(temperature_columns(spec), recorded.T, strict=True):
        columns[name] = values
    truth = Truth(
        kappa=spec.kappa,
        C=spec.C,
        sigma=spec.sigma,
        h_obs=h[lv],
        effects=effects,
        t=t_rows,
        T_clean=T_clean,
        z=z,
        T_initial=profiles[0].copy(),
        q_ground=q_ground,
        q_evap=q_evap_rows,
        noise_rms=float(np.sqrt(np.mean((spec.sigma * noise[:, : depths.size]) ** 2))),
        seed=spec.seed,
    )
    return columns, truth
