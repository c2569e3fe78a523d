"""The surface energy balance: wind-driven h, evaporation after rain, evapotranspiration, a
radiometer scale."""

from __future__ import annotations

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal, Uniform
from ..base import Extension
from ..registry import register_extension


@register_extension
class WindConvection(Extension):
    """h(t) = h_a + h_b v(t) from the measured wind, instead of free h pieces."""

    name = "wind_convection"
    hint = "surface misfit that follows the wind speed"
    replaces_h = True
    signals = ("corr:wind", "corr:T_air-T_s")

    def start_values(self, meas, base):
        """Start from the still-air and windy h the fitted pieces suggest (2 starts)."""
        return [{"h_a": 5.0, "h_b": 3.0}, {"h_a": 10.0, "h_b": 1.0}]

    def parameters(self, meas):
        if meas.wind is None:
            raise ValueError("wind_convection needs a 'wind' column in the data")
        return [
            Parameter("h_a", 5.0, 0.0, 100.0, prior=TruncatedNormal(5.0, 5.0), unit="W m-2 K-1",
                      description="still-air heat transfer coefficient"),
            Parameter("h_b", 3.0, 0.0, 50.0, prior=TruncatedNormal(3.0, 3.0),
                      unit="W m-3 K-1 s", description="wind sensitivity of h"),
        ]

    def surface(self, coeffs, p, model):
        v = model.meas.wind
        v_mid = 0.5 * (v[:-1] + v[1:])
        coeffs.h = p["h_a"][:, None] + p["h_b"][:, None] * v_mid[None, :]


@register_extension
class Evaporation(Extension):
    r"""A latent heat sink at the surface after rain, driven by the ``rain`` column.

    .. math:: q_{evap}(t) = A \sum_{k: t_k \le t} r_k \exp(-(t - t_k)/\tau)

    with ``evap_A`` (W m-2 per mm of rain) and ``evap_tau`` (hours); flux out of the ground.
    """

    name = "evaporation"
    hint = "surface too warm after rain"
    signals = ("corr:rain",)

    def parameters(self, meas):
        if meas.rain is None:
            raise ValueError("evaporation needs a 'rain' column in the data")
        return [
            Parameter("evap_A", 0.0, 0.0, 500.0, prior=TruncatedNormal(0.0, 50.0),
                      unit="W m-2 mm-1", description="latent sink per mm of rain"),
            Parameter("evap_tau", 3.0, 0.25, 48.0, prior=TruncatedNormal(3.0, 3.0, 0.25),
                      unit="h", description="drying time scale"),
        ]

    def null_values(self, meas):
        return {"evap_A": 0.0, "evap_tau": 3.0}

    def surface(self, coeffs, p, model):
        t, rain = model.meas.t, model.meas.rain
        tau = p["evap_tau"] * 3600.0
        s = np.zeros_like(tau)
        sink = np.empty((tau.size, t.size))
        for j in range(t.size):  # short recursion over observation times, vectorised over sets
            if j:
                s = s * np.exp(-(t[j] - t[j - 1]) / tau)
            s = s + rain[j]
            sink[:, j] = s
        coeffs.q -= p["evap_A"][:, None] * sink


@register_extension
class RadiationFactor(Extension):
    """The ground absorbs ``rad_factor`` x the recorded q_net (radiometer calibration).

    Not identifiable on its own: scaling kappa, C, h and this factor together leaves the
    equations unchanged, only the priors on kappa or C pin it.
    """

    name = "radiation_factor"
    hint = "daytime amplitude wrong at every depth in proportion to net radiation"
    signals = ("corr:q_net", "amplitude")

    def parameters(self, meas):
        return [Parameter("rad_factor", 1.0, 0.3, 2.0, prior=TruncatedNormal(1.0, 0.1),
                          description="scale on the recorded net radiation")]

    def null_values(self, meas):
        return {"rad_factor": 1.0}

    def surface(self, coeffs, p, model):
        coeffs.q += (p["rad_factor"] - 1.0)[:, None] * model.meas.q_net[None, :]


def saturation(T_air: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(e_s, s)``: saturation vapour pressure (kPa) and its slope (kPa K-1) at ``T_air``
    (degC), Tetens' formula as in FAO-56."""
    T = np.asarray(T_air, float)
    es = 0.6108 * np.exp(17.27 * T / (T + 237.3))
    return es, 4098.0 * es / (T + 237.3) ** 2


def priestley_taylor_weight(T_air: np.ndarray) -> np.ndarray:
    """``s / (s + gamma_psy)`` at the air temperature (degC): ``s`` the slope of the saturation
    vapour pressure curve (:func:`saturation`), ``gamma_psy = 0.066`` kPa K-1 (FAO-56)."""
    s = saturation(T_air)[1]
    return s / (s + 0.066)


@register_extension
class Evapotranspiration(Extension):
    r"""Latent heat leaving a vegetated or wet surface: a share of the available energy.

    .. math:: LE(t) = \alpha\,\frac{s(T_a)}{s(T_a) + \gamma}\,\max(q_\mathrm{net}(t), 0)

    (the Priestley–Taylor form with the net radiation as the available energy: the ground heat
    flux, 5-20 % of it by day over grass, is left in), ``et_alpha`` free (1.26 for well-watered
    grass, 0 for a dry surface). Flux out of the ground's surface balance.
    """

    name = "evapotranspiration"
    hint = ("surface too warm by day at every depth: net radiation that leaves as latent heat "
            "over vegetation or wet ground is pushed into the ground")
    signals = ("corr:q_net", "amplitude", "phase_lag")

    def parameters(self, meas):
        return [Parameter("et_alpha", 0.0, 0.0, 1.6, prior=Uniform(0.0, 1.6), unit="-",
                          description="Priestley-Taylor coefficient of the latent heat flux")]

    def null_values(self, meas):
        return {"et_alpha": 0.0}

    def start_values(self, meas, base):
        return [{"et_alpha": 0.6}, {"et_alpha": 1.2}]

    def surface(self, coeffs, p, model):
        meas = model.meas
        avail = priestley_taylor_weight(meas.T_air) * np.clip(meas.q_net, 0.0, None)
        coeffs.q -= p["et_alpha"][:, None] * avail[None, :]
