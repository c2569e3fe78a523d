r"""The surface energy balance with the latent heat in the Penman–Monteith form: where the record
has the relative humidity (``RH``, %, in the case CSV or the ``[data] extras`` CSV; AmeriFlux's
``RH`` through the preset) or the dew point (``T_dew``, degC; where neither is measured,
``[data] dew_below_tmin`` estimates it from the daily minimum air temperature, FAO-56:
:mod:`pavement_mcmc.data.humidity`), the evaporative demand of the air enters the latent heat, and the
surface's own control is a resistance that may drift from day to day:

.. math::

    LE = f\,(R_n - G) + V, \qquad
    f = \frac{s}{s + \gamma\,(1 + r_s h_H / \rho c_p)}, \qquad
    V = \frac{h_H\,D}{s + \gamma\,(1 + r_s h_H / \rho c_p)}, \qquad
    D = e_s(T_a)\,(1 - RH/100),

with :math:`h_H = \rho c_p / r_a` the sensible heat law's transfer coefficient of
:mod:`.energy` (``eb_h0 + eb_h1 u``, W m-2 K-1: the same aerodynamic resistance carries heat
and vapour), ``s`` the slope of the saturation vapour pressure :math:`e_s` (Tetens, kPa K-1),
``gamma`` 0.066 kPa K-1, :math:`\rho c_p` = 1200 J m-3 K-1, and :math:`r_s` the bulk surface
(canopy) resistance, one per day of the window (``eb_rs_1`` ...; s m-1: about 50-100 over
well-watered grass, 200-1000 over a drying or sparse surface, thousands over dry bare soil;
bounds 0-5000). The available energy is :math:`R_n - G` at every hour, as FAO-56's hourly
form: at night it is negative where the ground gives less heat than the surface radiates
(dew, LE < 0, unless a dry air's :math:`V` outweighs it) and positive where it gives more.
Switching the radiative term off at night (:math:`f = 0` where :math:`R_n \le 0`) recovered
the surface resistance of 18 twins whose simulator evaporates on :math:`\max(R_n - G, 0)` 29 %
off in the median against 8 % for this form (docs/VALIDATION.md section 4). At :math:`r_s = 0` and
:math:`D = 0` it is the equilibrium evaporation :math:`s (R_n - G) / (s + \gamma)`; a large
:math:`r_s` chokes both terms, the surface's supply limit.

With G the unknown flux into the surface the balance stays a linear (Robin) boundary condition:
:math:`G = R_n - H - LE` with :math:`H = h_H (T_s - T_a)` solves to

.. math::

    G = R_n + \frac{h_H}{1 - f} (T_a - T_s) - \frac{V}{1 - f},

so the law sets the solver's ``h`` to :math:`h_H / (1 - f)` and takes :math:`V / (1 - f)` off
its ``q``; :meth:`EnergyBalancePM.latent` gives LE from the solved G.

``energy_balance_pm`` (one resistance a day) and ``energy_balance_pm_window`` (one for the
window) replace ``energy_balance`` / ``energy_balance_window`` where the record has RH; without
it they refuse the record, saying so. H is the same bulk law; ``canopy``, ``surface_layer`` and
``shading`` combine with them as with the Priestley–Taylor forms, and :func:`.energy.energy_partition`
gives the four fluxes.
"""

from __future__ import annotations

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal
from ..registry import register_extension
from .energy import EnergyBalance, day_index, n_days_of
from .surface import saturation

#: psychrometric constant, kPa K-1 (FAO-56 at sea level)
GAMMA = 0.066
#: volumetric heat capacity of air, J m-3 K-1 (1.2 kg m-3 x 1005 J kg-1 K-1)
RHO_CP = 1200.0


def humidity(meas) -> np.ndarray | None:
    """The relative humidity (n_obs,), %, of ``meas``: its ``RH``, else from its dew point
    ``T_dew`` (measured, or estimated by ``[data] dew_below_tmin``, FAO-56:
    :mod:`pavement_mcmc.data.humidity`) as ``100 e_s(T_d) / e_s(T_a)``; None without either
    or with a gap (the law needs one at every time)."""
    extras = getattr(meas, "extras", {})
    if "RH" in extras:
        rh = np.asarray(extras["RH"], float)
    elif "T_dew" in extras:
        rh = 100.0 * saturation(extras["T_dew"])[0] / saturation(meas.T_air)[0]
    else:
        return None
    return rh if bool(np.all(np.isfinite(rh))) else None


def has_humidity(meas) -> bool:
    """Whether ``meas`` holds a humidity (:func:`humidity`) without gaps."""
    return humidity(meas) is not None


def pm_terms(Rn, T_air, RH, h_H, r_s) -> tuple[np.ndarray, np.ndarray]:
    """``(f, V)`` of the module doc: the share of the available energy R_n - G and the vapour
    flux (W m-2) that leave as latent heat. Arrays broadcast (``h_H`` and ``r_s`` may be
    (n_sets, n_obs), the others (n_obs,)); both come out in the shape of ``Rn`` broadcast
    with them."""
    es, s = saturation(T_air)
    D = es * (1.0 - np.clip(np.asarray(RH, float), 0.0, 100.0) / 100.0)
    den = np.broadcast_to(s + GAMMA * (1.0 + r_s * h_H / RHO_CP),
                          np.broadcast_shapes(np.shape(Rn), np.shape(s * r_s * h_H)))
    return s / den, h_H * D / den


def penman_monteith(Rn, T_air, RH, h_H, r_s, G=0.0) -> np.ndarray:
    """Latent heat flux LE = f (R_n - G) + V (W m-2) of the module doc, ``G`` the heat flux
    into the surface (W m-2)."""
    f, V = pm_terms(Rn, T_air, RH, h_H, r_s)
    return f * (np.asarray(Rn, float) - G) + V


@register_extension
class EnergyBalancePM(EnergyBalance):
    """Surface energy balance ``G = R_n - H - LE`` with LE in the Penman–Monteith form (the
    relative humidity's vapour pressure deficit, one surface resistance a day; module doc)."""

    name = "energy_balance_pm"
    hint = ("the net radiation does not all enter the ground: sensible heat (with the wind) and "
            "latent heat (the air's humidity and a surface resistance) leave the surface")
    latent_form = ("Penman–Monteith: the air's vapour pressure deficit from the relative "
                   "humidity and a surface resistance")

    def rs_names(self, meas) -> list[str]:
        """``eb_rs_1 .. eb_rs_D``, one per day of the window."""
        return [f"eb_rs_{d + 1}" for d in range(n_days_of(meas.t))]

    def parameters(self, meas):
        if not has_humidity(meas):
            raise ValueError(f"{self.name} needs the air's humidity without gaps: an 'RH' (%) or "
                             "'T_dew' (degC) column in the case CSV or the [data] extras CSV, or "
                             "its FAO-56 estimate from the air temperature ([data] "
                             "dew_below_tmin = 0, 2-4 over arid ground); or use energy_balance "
                             "(Priestley-Taylor)")
        h = [p for p in super().parameters(meas) if not p.name.startswith("eb_alpha")]
        names = self.rs_names(meas)
        group = "" if len(names) == 1 else "eb_rs"
        return [*h, *[Parameter(n, 100.0, 0.0, 5000.0, prior=TruncatedNormal(200.0, 1000.0, 0.0),
                                unit="s m-1", description="bulk surface resistance to vapour, "
                                + (f"day {d + 1}" if group else "the window"), group=group)
                      for d, n in enumerate(names)]]

    def terms(self, p, meas) -> tuple[np.ndarray, np.ndarray]:
        """``(f, V)`` (n_sets, n_obs) at the parameter sets ``p`` (:func:`pm_terms`)."""
        names = self.rs_names(meas)
        rs = np.stack([np.asarray(p[n], float) for n in names], axis=1)
        rs_t = rs[:, day_index(meas.t, len(names))]
        return pm_terms(meas.q_net, meas.T_air, humidity(meas), self.transfer(p, meas), rs_t)

    def latent(self, p, meas, G=None) -> np.ndarray:
        """LE (n_sets, n_obs), W m-2, given ``G``: what R_n loses at the spot besides LE and H
        (the solved heat flux into the surface, and what a shadow keeps off it)."""
        f, V = self.terms(p, meas)
        return f * (np.asarray(meas.q_net, float)[None, :] - (0.0 if G is None else G)) + V

    def surface(self, coeffs, p, model):
        f, V = self.terms(p, model.meas)
        self.set_h(coeffs, self.transfer(p, model.meas) / (1.0 - f))
        coeffs.q -= V / (1.0 - f)


@register_extension
class EnergyBalancePMWindow(EnergyBalancePM):
    """The Penman–Monteith surface energy balance with one surface resistance ``eb_rs`` for the
    whole window (module doc)."""

    name = "energy_balance_pm_window"

    def rs_names(self, meas) -> list[str]:
        return ["eb_rs"]
