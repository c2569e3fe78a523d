r"""The surface energy balance with the latent heat in the Penman–Monteith form: where the record
has the relative humidity (``RH``, %, in the case CSV or the ``[data] extras`` CSV; AmeriFlux's
``RH`` through the preset), the evaporative demand of the air enters the latent heat, and the
surface's own control is a resistance that may drift from day to day:

.. math::

    LE = \frac{s\,\max(R_n, 0) + h_H\,D}{s + \gamma\,(1 + r_s h_H / \rho c_p)}, \qquad
    D = e_s(T_a)\,(1 - RH/100),

with :math:`h_H = \rho c_p / r_a` the sensible heat law's transfer coefficient of
:mod:`.energy` (``eb_h0 + eb_h1 u``, W m-2 K-1: the same aerodynamic resistance carries heat
and vapour), ``s`` the slope of the saturation vapour pressure :math:`e_s` (Tetens, kPa K-1),
``gamma`` 0.066 kPa K-1, :math:`\rho c_p` = 1200 J m-3 K-1, and :math:`r_s` the bulk surface
(canopy) resistance, one per day of the window (``eb_rs_1`` ...; s m-1: about 50-100 over
well-watered grass, 200-1000 over a drying or sparse surface, thousands over dry bare soil;
bounds 0-5000). At :math:`r_s = 0` and :math:`D = 0` it is the equilibrium evaporation
:math:`s R_n / (s + \gamma)`; for large :math:`r_s` it falls as
:math:`(s R_n + h_H D)\,\rho c_p / (\gamma r_s h_H)`, the surface's supply limit. The
available energy is :math:`\max(R_n, 0)` as in the Priestley–Taylor form of :mod:`.energy`
(the ground heat flux left in); at night a dry air (``D > 0``) may still draw latent heat
through the vapour term (no dew is modelled).

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

#: psychrometric constant, kPa K-1 (FAO-56 at sea level)
GAMMA = 0.066
#: volumetric heat capacity of air, J m-3 K-1 (1.2 kg m-3 x 1005 J kg-1 K-1)
RHO_CP = 1200.0


def saturation(T_air: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(e_s, s)``: saturation vapour pressure (kPa) and its slope (kPa K-1) at ``T_air``
    (degC), Tetens' formula as in FAO-56."""
    T = np.asarray(T_air, float)
    es = 0.6108 * np.exp(17.27 * T / (T + 237.3))
    return es, 4098.0 * es / (T + 237.3) ** 2


def penman_monteith(Rn, T_air, RH, h_H, r_s) -> np.ndarray:
    """Latent heat flux (W m-2) of the module doc; arrays broadcast (``h_H`` and ``r_s`` may be
    (n_sets, n_obs), the others (n_obs,))."""
    es, s = saturation(T_air)
    D = es * (1.0 - np.clip(np.asarray(RH, float), 0.0, 100.0) / 100.0)
    return ((s * np.clip(np.asarray(Rn, float), 0.0, None) + h_H * D)
            / (s + GAMMA * (1.0 + r_s * h_H / RHO_CP)))


@register_extension
class EnergyBalancePM(EnergyBalance):
    """Surface energy balance ``G = R_n - H - LE`` with LE in the Penman–Monteith form (the
    relative humidity's vapour pressure deficit, one surface resistance a day; module doc)."""

    name = "energy_balance_pm"
    hint = ("the net radiation does not all enter the ground: sensible heat (with the wind) and "
            "latent heat (the air's humidity and a surface resistance) leave the surface")

    def rs_names(self, meas) -> list[str]:
        """``eb_rs_1 .. eb_rs_D``, one per day of the window."""
        return [f"eb_rs_{d + 1}" for d in range(n_days_of(meas.t))]

    def parameters(self, meas):
        rh = getattr(meas, "extras", {}).get("RH")
        if rh is None or not np.all(np.isfinite(rh)):
            raise ValueError(f"{self.name} needs the relative humidity (an 'RH' column, %, in the "
                             "case CSV or the [data] extras CSV, without gaps); without it use "
                             "energy_balance (Priestley-Taylor)")
        h = [p for p in super().parameters(meas) if not p.name.startswith("eb_alpha")]
        names = self.rs_names(meas)
        group = "" if len(names) == 1 else "eb_rs"
        return [*h, *[Parameter(n, 100.0, 0.0, 5000.0, prior=TruncatedNormal(200.0, 1000.0, 0.0),
                                unit="s m-1", description="bulk surface resistance to vapour, "
                                + (f"day {d + 1}" if group else "the window"), group=group)
                      for d, n in enumerate(names)]]

    def latent(self, p, meas) -> np.ndarray:
        names = self.rs_names(meas)
        rs = np.stack([np.asarray(p[n], float) for n in names], axis=1)
        rs_t = rs[:, day_index(meas.t, len(names))]
        return penman_monteith(meas.q_net, meas.T_air, meas.extras["RH"], self.transfer(p, meas),
                               rs_t)


@register_extension
class EnergyBalancePMWindow(EnergyBalancePM):
    """The Penman–Monteith surface energy balance with one surface resistance ``eb_rs`` for the
    whole window (module doc)."""

    name = "energy_balance_pm_window"

    def rs_names(self, meas) -> list[str]:
        return ["eb_rs"]
