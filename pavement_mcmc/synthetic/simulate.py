"""Twin datasets: weather -> deep fine-grid ground column -> sensors with noise and hidden effects."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..data.times import hour_of_day, times_after
from .column import KELVIN, STEFAN_BOLTZMANN, conductive_flux, march
from .effects import DEFAULT_RAIN, resolve_effects
from .forcing import Clock, Forcing, forcing_at_levels, ground_sinks
from .ground import build_ground
from .outputs import (
    ir_column,
    plate_columns,
    recorded_forcing,
    recorded_temperatures,
    sensor_readings,
    sensor_temperatures,
    tower_columns,
)
from .processes import penman_monteith_terms, rain_per_row, relative_humidity
from .soil_water import check_soil_water, recorded_swc, soil_water_terms
from .weather import make_weather

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
        degC; None: mean air temperature + the climate's offset (+8 degC summer, -0.5 spring).
    dz_mm : cell size in the resolved zone (down to 2 cm below the deepest sensor, plate,
        source or interface), mm. None: 0.25 if ``bottom_cm`` <= 10 (pavement geometry), else 1.
    dt_s : target time step, s (rounded down to divide the sampling step). None: 5 if
        ``bottom_cm`` <= 10, else 30 (see :func:`resolved_grid`).
    time0 : ISO 8601 UTC time of the first row (its clock sets the hour of day).
    climate : weather climate, "summer" (June over asphalt) or "spring" (early April over
        grass), see :data:`~pavement_mcmc.synthetic.weather.CLIMATES`.
    flux_depths_cm : nominal depths of heat-flux plates, cm from the soil surface; each adds a
        ``G_<d>cm`` column (W m-2, positive downward).
    plate_factor : calibration factor of the plates: reading = factor x true flux x
        (1 + plate_rel_noise N1) + plate_abs_noise N2 (N1, N2 standard normal from their own
        random stream).
    plate_rel_noise : relative noise of the plates (-).
    plate_abs_noise : absolute noise of the plates, W m-2.
    et_available : available energy of the ``evapotranspiration`` effect: "net_minus_ground"
        (R_n - G, Priestley-Taylor's) or "net" (R_n alone, the form of the inversion's
        ``energy_balance`` entry).
    vapour_kPa : water vapour pressure of the air (kPa; 0: none): an ``RH`` column (%) from it
        and the air temperature.
    surface_resistance : with ``vapour_kPa``, latent heat in the Penman-Monteith form leaves the
        surface: LE = [s A + h D] / [s + gamma (1 + r_s h / rho c_p)], r_s this (s m-1), h the
        twin's convective h(t), D the vapour pressure deficit, A the ``et_available`` energy
        (not with the ``evapotranspiration`` effect; ``processes.penman_monteith_terms``).
    tower : closure of a flux tower over the twin (0: none): with 0.85, say, ``H`` and ``LE``
        columns (W m-2, leaving the surface) read 0.85 x the true sensible heat h (T_s - T_air)
        and latent heat (evapotranspiration and evaporation), each x (1 + 0.1 N1) + 5 N2 W m-2
        (N1, N2 from their own random stream): a tower that misses part of the turbulent flux,
        as real ones do (their H + LE typically close 70-90 % of R_n - G).
    ir_view : share of an infrared thermometer's view stopped in a ``surface_layer`` (0: no
        thermometer): it looks down into the porous layer, each depth's radiance weighted by
        where the view is stopped (Beer's law), the rest of the view reaching the soil
        surface below (:func:`~.outputs.ir_column`); without a layer, or at 1, it reads the
        column's top. A ``T_surf_IR`` column (degC), from its own random stream.
    ir_offset, ir_noise : the thermometer's offset and noise sd, degC.
    swc_fc : field capacity theta_fc (m3 m-3) of a top-soil water content series (0: none): an
        ``SWC`` column (m3 m-3, +-0.01 noise from its own random stream) of a 5 cm layer wetted
        by the rain and ``swc_events`` and drying down exponentially, and a latent heat
        ``swc_alpha beta(theta) s/(s + gamma) max(R_n - G, 0)`` with the Noilhan-Planton
        beta (:mod:`.soil_water`; not with ``evapotranspiration`` or ``surface_resistance``).
    swc_alpha : Priestley-Taylor coefficient of that latent heat (0: SWC recorded, no latent
        heat).
    swc_tau_h : e-folding time of the dry-down, h.
    swc_events : wettings ``((hour, mm), ...)`` besides the rain, hours from the window start
        (negative: in the spin-up, so that a window can start wet).
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
    dz_mm: float | None = None
    dt_s: float | None = None
    time0: str = "2004-06-06T00:00:00Z"
    climate: str = "summer"
    flux_depths_cm: tuple = ()
    plate_factor: float = 1.0
    plate_rel_noise: float = 0.05
    plate_abs_noise: float = 2.0
    et_available: str = "net_minus_ground"
    tower: float = 0.0
    vapour_kPa: float = 0.0
    surface_resistance: float | None = None
    ir_view: float = 0.0
    ir_offset: float = 1.0
    ir_noise: float = 0.3
    swc_fc: float = 0.0
    swc_alpha: float = 1.0
    swc_tau_h: float = 36.0
    swc_events: tuple = ()


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
    q_evap : (n_obs,) latent heat flux out of the ground at each row (``evaporation``), W m-2.
    noise_rms : RMS of the noise actually added to the observed sensors, degC.
    seed : the spec's seed.
    q_et : (n_obs,) evapotranspiration LE at each row (``evapotranspiration``), W m-2.
    flux : ``G_<d>cm`` -> (n_obs,) true conductive flux at each plate's depth, W m-2, positive
        downward (before the plate's calibration factor and noise).
    profiles : (n_obs, n_nodes) true temperature at every node at each row, degC.
    soil_top : depth of the soil surface in the simulated column, m (the ``surface_layer``
        thickness, else 0): nominal depth d sits at ``z = soil_top + d``.
    swc : (n_obs,) true top-soil water content at each row (``swc_fc``), m3 m-3; its latent
        heat is ``q_et``.
    dz : cell size of the resolved zone, m.
    dt : solver time step, s.
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
    q_et: np.ndarray | None = None
    flux: dict = field(default_factory=dict)
    profiles: np.ndarray | None = None
    soil_top: float = 0.0
    dz: float = 0.0
    dt: float = 0.0
    swc: np.ndarray | None = None


def temperature_columns(spec: SyntheticSpec) -> list[str]:
    """CSV names of the temperature columns: observed sensors, then the bottom one."""
    return [f"T_{d:g}cm" for d in (*spec.depths_cm, spec.bottom_cm)]


def flux_columns(spec: SyntheticSpec) -> list[str]:
    """CSV names of the heat-flux plate columns, ``G_<d>cm``, in the order of the spec."""
    return [f"G_{d:g}cm" for d in spec.flux_depths_cm]


def resolved_grid(spec: SyntheticSpec) -> tuple[float, float]:
    """Cell size of the resolved zone (m) and target time step (s) the spec asks for.

    Defaults: 0.25 mm and 5 s for the paper's pavement geometry (bottom sensor at <= 10 cm;
    halving both moves the 0-5 cm temperatures by ~1e-4 degC); 1 mm and 30 s for deeper,
    field-like geometries (2-50 cm sensors: 3e-4 degC from 0.25 mm and 5 s, 25 times faster).
    """
    shallow = spec.bottom_cm <= 10.0
    dz_mm = spec.dz_mm if spec.dz_mm is not None else (0.25 if shallow else 1.0)
    dt_s = spec.dt_s if spec.dt_s is not None else (5.0 if shallow else 30.0)
    if not (dz_mm > 0 and dt_s > 0):
        raise ValueError(f"dz_mm={dz_mm} and dt_s={dt_s} must be positive")
    return dz_mm / 1000.0, float(dt_s)


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
    plates = np.asarray(spec.flux_depths_cm, float)
    if plates.size and (np.any(plates < 0) or np.any(plates / 100.0 > spec.column_cm / 100.0 - 0.05)):
        raise ValueError(f"flux_depths_cm={spec.flux_depths_cm} must lie in [0, column_cm - 5] cm")
    if len(set(flux_columns(spec))) != plates.size:
        raise ValueError(f"flux_depths_cm={spec.flux_depths_cm} holds the same depth twice")
    if spec.et_available not in ("net_minus_ground", "net"):
        raise ValueError(f"et_available={spec.et_available!r}; valid: 'net_minus_ground', 'net'")
    if spec.tower < 0 or spec.vapour_kPa < 0:
        raise ValueError(f"tower={spec.tower:g} and vapour_kPa={spec.vapour_kPa:g} must be >= 0 "
                         "(0: no tower, no RH column)")
    if spec.surface_resistance is not None and (
            spec.vapour_kPa <= 0 or spec.surface_resistance < 0
            or "evapotranspiration" in (spec.effects or {})):
        raise ValueError("surface_resistance (Penman-Monteith latent heat) needs vapour_kPa > 0, "
                         "a resistance >= 0 and no 'evapotranspiration' effect")
    check_soil_water(spec)
    if not (spec.plate_factor > 0 and spec.plate_rel_noise >= 0 and spec.plate_abs_noise >= 0):
        raise ValueError("plate_factor must be positive, plate_rel_noise and plate_abs_noise >= 0")
    return depths, bottom


def _iso_times(time0: str, t: np.ndarray) -> np.ndarray:
    return np.asarray(times_after(time0, t))


def simulate(spec: SyntheticSpec) -> tuple[dict[str, np.ndarray], Truth]:
    """Generate one twin dataset.

    Parameters
    ----------
    spec : what to generate.

    Returns
    -------
    columns : the CSV contract's columns, unrounded: ``time`` (ISO 8601 strings), ``T_air``
        (degC), ``q_net`` (W m-2), ``wind`` (m s-1), ``rain`` (mm per row), ``T_<d>cm`` (degC),
        then ``G_<d>cm`` (W m-2, positive downward) for each heat-flux plate.
    truth : the true parameters, h(t), effects, noise-free temperatures and fluxes.
    """
    depths, bottom = _check(spec)
    dz, dt_target = resolved_grid(spec)
    effects = resolve_effects(spec.effects or {}, spec.kappa, spec.C, spec.depths_cm, spec.bottom_cm)
    seq = np.random.SeedSequence(spec.seed)
    rng_weather, rng_noise, rng_rows = (np.random.default_rng(s) for s in seq.spawn(3))
    rng_plates = np.random.default_rng(seq.spawn(1)[0])  # the 4th child: the first 3 unchanged
    clock = Clock.of(spec, dt_target)
    rain_events = spec.rain if spec.rain is not None else (DEFAULT_RAIN if "evaporation" in effects else ())
    start_hour = float(hour_of_day(spec.time0, 0.0))
    weather = make_weather(rng_weather, clock.t_levels[0], clock.t_levels[-1], tuple(rain_events),
                           start_hour, spec.climate)
    # rows kept (irregular sampling) and their rain, accumulated over dropped rows
    keep = rng_rows.random(clock.n_rows) >= spec.drop_fraction
    keep[0] = keep[-1] = True
    rain_all = rain_per_row(tuple(rain_events), clock.t_rows_all, spec.hours)
    rain = np.round(np.diff(np.cumsum(rain_all)[keep], prepend=0.0), 1)
    t_rows = clock.t_rows_all[keep]

    fo = forcing_at_levels(spec, effects, weather, clock, start_hour)
    q_evap_rows, q_sink, pt_factor = ground_sinks(effects, t_rows, rain, clock.t_levels, fo.T_air)
    if spec.surface_resistance is not None:  # Penman-Monteith: a factor on A, a vapour flux
        pt_factor, q_vapour = penman_monteith_terms(fo.T_air, fo.h, spec.vapour_kPa,
                                                    spec.surface_resistance)
        q_sink = q_sink + q_vapour
    if spec.swc_fc > 0:  # the top soil's water content and the latent heat it limits
        theta, swc_factor = soil_water_terms(spec, clock, rain_all, fo.T_air)
        pt_factor = swc_factor if swc_factor is not None else pt_factor
    ground, run = _march_ground(spec, effects, depths, bottom, dz, weather, clock, fo, q_sink,
                                pt_factor)
    profiles = run.profiles[clock.n_spin:][keep]
    z, true_depths = ground.z, ground.sensor_z
    T_clean = sensor_temperatures(z, true_depths, profiles)
    lv = ((np.arange(clock.n_rows) + clock.n_spin) * clock.substeps)[keep]
    emitted = fo.e_rad * STEFAN_BOLTZMANN * (profiles[:, 0] + KELVIN) ** 4
    q_ground = fo.q_abs[lv] - emitted

    # noise: drawn for every regular row, so dropping rows or adding effects leaves it unchanged
    noise = rng_noise.standard_normal((clock.n_rows, true_depths.size + 3))[keep]
    t_all = (np.arange(clock.n_spin + clock.n_rows) - clock.n_spin) * clock.step
    reading = sensor_readings(spec, effects, T_clean, z, true_depths, run.profiles, t_all,
                              clock.n_spin, keep, fo.sw[lv])
    recorded = recorded_temperatures(spec, effects, reading, noise)
    T_air_rec, q_rec = recorded_forcing(spec, fo.T_air[lv], (fo.q_open[lv] - emitted) / fo.f,
                                        noise)
    columns: dict[str, np.ndarray] = {
        "time": _iso_times(spec.time0, t_rows),
        "T_air": T_air_rec,
        "q_net": q_rec,
        "wind": np.round(fo.wind[lv], 2),
        "rain": rain,
    }
    if spec.vapour_kPa > 0:
        columns["RH"] = relative_humidity(fo.T_air[lv], spec.vapour_kPa)
    for name, values in zip(temperature_columns(spec), recorded.T, strict=True):
        columns[name] = values
    flux = conductive_flux(ground.column, profiles, ground.plate_z, ground.beta)
    plates, flux_true = plate_columns(spec, flux_columns(spec), flux, rng_plates, clock.n_rows, keep)
    columns.update(plates)
    if spec.tower > 0:  # its own random stream (the 5th child): the others stay unchanged
        H = fo.h[lv] * (profiles[:, 0] - fo.T_air[lv])
        columns.update(tower_columns(spec.tower, H, run.latent[lv] + q_sink[lv],
                                     np.random.default_rng(seq.spawn(1)[0])))
    if spec.ir_view > 0:  # its own random stream too
        if spec.ir_view > 1 or (spec.ir_view < 1 and not ground.soil_top):
            raise ValueError(f"ir_view must be in (0, 1], and below 1 only over a surface_layer "
                             f"(the share of the view it stops), got {spec.ir_view}")
        columns["T_surf_IR"] = ir_column(spec, z, profiles, ground.soil_top,
                                         np.random.default_rng(seq.spawn(1)[0]))
    swc = None
    if spec.swc_fc > 0:  # its own random stream too
        swc = theta[clock.n_spin:][keep]
        columns["SWC"] = recorded_swc(swc, np.random.default_rng(seq.spawn(1)[0]))

    truth = Truth(
        kappa=spec.kappa, C=spec.C, sigma=spec.sigma, h_obs=fo.h[lv], effects=effects, t=t_rows,
        T_clean=T_clean, z=z, T_initial=profiles[0].copy(), q_ground=q_ground, q_evap=q_evap_rows,
        noise_rms=float(np.sqrt(np.mean((spec.sigma * noise[:, : depths.size]) ** 2))),
        seed=spec.seed, q_et=run.latent[lv], flux=flux_true, profiles=profiles,
        soil_top=ground.soil_top, dz=dz, dt=clock.dt, swc=swc,
    )
    return columns, truth


def _march_ground(spec, effects, depths, bottom, dz, weather, clock: Clock, fo: Forcing,
                  q_sink, pt_factor):
    """The ground (optional thatch on one or two soil layers; nominal depths from the soil
    surface) and its march from a uniform ``T_deep`` over spin-up and window."""
    plates = np.asarray(spec.flux_depths_cm, float) / 100.0
    ground = build_ground(spec.kappa, spec.C, effects, depths, bottom, spec.column_cm / 100.0, dz, plates)
    T_deep = spec.T_deep
    if T_deep is None:
        T_deep = weather.params["T_mean"] + weather.params["T_deep_offset"]
    run = march(
        ground.column,
        np.full(ground.z.size, T_deep),
        clock.dt,
        fo.T_air,
        fo.h,
        fo.q_abs,
        q_sink,
        np.full(clock.t_levels.size, T_deep),
        emissivity=fo.e_rad,
        beta=ground.beta,
        record_every=clock.substeps,
        source=ground.source,
        pt_factor=pt_factor,
        et_ground=spec.et_available == "net_minus_ground",
    )
    return ground, run
