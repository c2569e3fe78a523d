r"""A twin's top-soil water content and the latent heat it limits (``SyntheticSpec.swc_fc``).

The water content :math:`\theta` (m3 m-3) of a 5 cm top layer is a bucket on the regular rows
of spin-up and window: it starts at the residual content at the start of the spin-up, gains
the water :math:`w_k` (mm) of each row (the twin's rain and the spec's ``swc_events``), at
most up to the porosity, and dries down exponentially toward the residual content:

.. math::

    \theta_k = \min\!\big(\phi,\ \theta_r + (\theta_{k-1} - \theta_r)\,e^{-\Delta t/\tau}
               + w_k / (1000\,d)\big),

with :math:`d` = :data:`LAYER_M`, :math:`\phi` = :data:`POROSITY`, :math:`\theta_r` =
:data:`RESIDUAL` and :math:`\tau` the spec's ``swc_tau_h``. The solver sees it linear between
rows. The latent heat leaving the surface is Priestley–Taylor on the available energy
(``et_available``, :math:`R_n - G` by default, G lagged one solver step as for the
``evapotranspiration`` effect) times the Noilhan & Planton (1989) soil-evaporation efficiency:

.. math::

    LE = \alpha\,\beta(\theta)\,\frac{s}{s + \gamma}\,\max(R_n - G, 0), \qquad
    \beta(\theta) = \tfrac14\big(1 - \cos(\pi\theta/\theta_{fc})\big)^2 \ (\theta < \theta_{fc}),
    \ 1 \text{ above},

:math:`\alpha` the spec's ``swc_alpha`` (0: the water content is recorded, no latent heat),
:math:`\theta_{fc}` its ``swc_fc``. Deliberately not the inversion's ``energy_balance_swc``
(a linear :math:`\min(1, \theta/\theta_{fc})` on :math:`R_n - G` while :math:`R_n > 0`, with
the share capped): no inverse crime. The
recorded ``SWC`` column is :math:`\theta` + :data:`SWC_NOISE` N (its own random stream),
clipped at 0.
"""

from __future__ import annotations

import numpy as np

from .forcing import PT_FACTOR_MAX
from .processes import priestley_taylor_factor
from .weather import HOUR

LAYER_M = 0.05
"""Depth of the top soil layer whose water content is recorded, m."""
POROSITY = 0.40
"""Largest water content of the layer (saturation), m3 m-3."""
RESIDUAL = 0.005
"""Water content the layer dries down toward, m3 m-3."""
SWC_NOISE = 0.01
"""sd of the recorded water content's Gaussian noise, m3 m-3."""


def drying_settings(theta_fc: float = 0.2, alpha: float = 1.0, **more) -> dict:
    """``SyntheticSpec`` settings (e.g. ``forecast_twins(spec=...)``) of a soil that dries down
    through a window: 20 mm 12 h before it fill the layer to the porosity, it holds about
    0.29 at the window's start, 0.20 a day later and 0.11 after two (``swc_tau_h`` 36 h, before
    the window's own rain), and a flux tower closing 100 % (the ``H`` and ``LE`` columns).
    ``alpha`` 0: the water content is recorded, no latent heat leaves."""
    return {"swc_fc": theta_fc, "swc_alpha": alpha, "swc_tau_h": 36.0,
            "swc_events": ((-12.0, 20.0),), "tower": 1.0, **more}


def check_soil_water(spec) -> None:
    """ValueError unless the spec's soil-water settings are usable (see ``SyntheticSpec``)."""
    if spec.swc_fc == 0:
        if spec.swc_events:
            raise ValueError("swc_events need swc_fc > 0 (the soil-water series)")
        return
    if not (RESIDUAL < spec.swc_fc <= POROSITY and spec.swc_alpha >= 0 and spec.swc_tau_h > 0):
        raise ValueError(f"swc_fc must be in ({RESIDUAL}, {POROSITY}], swc_alpha >= 0 and "
                         f"swc_tau_h > 0, got {spec.swc_fc}, {spec.swc_alpha}, {spec.swc_tau_h}")
    if spec.swc_alpha > 0 and ("evapotranspiration" in (spec.effects or {})
                               or spec.surface_resistance is not None):
        raise ValueError("a soil-water limited latent heat (swc_alpha > 0) cannot be combined "
                         "with the 'evapotranspiration' effect or surface_resistance")
    for event in spec.swc_events:
        hour, mm = event
        if not (-spec.spinup_hours <= hour <= spec.hours and mm >= 0):
            raise ValueError(f"swc_events {tuple(event)}: (hour, mm) with the hour in "
                             f"[-spinup_hours, hours] and mm >= 0")


def noilhan_planton(theta: np.ndarray, theta_fc: float) -> np.ndarray:
    """Soil-evaporation efficiency ``0.25 (1 - cos(pi theta / theta_fc))^2`` below ``theta_fc``,
    1 above (Noilhan & Planton 1989), dimensionless; theta, theta_fc in m3 m-3."""
    theta = np.clip(np.asarray(theta, float), 0.0, theta_fc)
    return 0.25 * (1.0 - np.cos(np.pi * theta / theta_fc)) ** 2


def water_content(t: np.ndarray, water_mm: np.ndarray, tau_h: float) -> np.ndarray:
    """The bucket of the module doc at the row times ``t`` (s), given the water ``water_mm``
    (mm) each row receives, m3 m-3."""
    theta = np.empty(t.size)
    level = RESIDUAL
    for k in range(t.size):
        if k:
            level = RESIDUAL + (level - RESIDUAL) * np.exp(-(t[k] - t[k - 1]) / (tau_h * HOUR))
        level = min(POROSITY, level + water_mm[k] / (1000.0 * LAYER_M))
        theta[k] = level
    return theta


def soil_water_terms(spec, clock, rain_rows: np.ndarray, T_air: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray | None]:
    """``(theta at every regular row of spin-up and window, factor or None)``: the water
    content, and ``alpha beta(theta) s/(s + gamma)`` at every solver level (None when
    ``swc_alpha`` is 0). ``rain_rows``: the rain (mm) of each regular window row."""
    t_all = (np.arange(clock.n_spin + clock.n_rows) - clock.n_spin) * clock.step
    water = np.zeros(t_all.size)
    water[clock.n_spin:] += rain_rows
    for hour, mm in spec.swc_events:  # on the first row at or after the event
        water[int(np.searchsorted(t_all, hour * HOUR - 1e-6))] += mm
    theta = water_content(t_all, water, spec.swc_tau_h)
    if spec.swc_alpha == 0:
        return theta, None
    beta = noilhan_planton(np.interp(clock.t_levels, t_all, theta), spec.swc_fc)
    factor = priestley_taylor_factor(T_air, spec.swc_alpha) * beta
    if factor.max() >= PT_FACTOR_MAX:
        raise ValueError(f"swc_alpha s/(s + gamma) reaches {factor.max():.3f}; the lagged "
                         f"closure needs < {PT_FACTOR_MAX}")
    return theta, factor


def recorded_swc(theta: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The recorded water content: ``theta`` + :data:`SWC_NOISE` N, clipped at 0, m3 m-3."""
    return np.clip(theta + SWC_NOISE * rng.standard_normal(theta.size), 0.0, None)
