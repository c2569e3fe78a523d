r"""The surface energy balance with a latent heat limited by the measured soil water: where the
record has the water content of its top soil (``SWC``, m3 m-3, in the case CSV or the
``[data] extras`` CSV, e.g. ``[data.columns] "SWC_5cm" = "SWC"``), a bare or sparse surface
evaporates as a wet one while the soil holds water and stops as it dries:

.. math::

    LE = f\,(R_n - G), \qquad
    f = \min\!\Big(\alpha\,\beta(\theta)\,\frac{s(T_a)}{s(T_a) + \gamma},\ f_{max}\Big)
        \ \text{while } R_n > 0, \ 0 \text{ at night}, \qquad
    \beta(\theta) = \min(1, \theta / \theta_{fc}),

- ``\theta`` the measured water content at each time, ``\theta_{fc}`` (``eb_theta_fc``) the
  content above which the surface is not short of water (about the field capacity: 0.10-0.15
  in a sand, 0.25 in a loam, 0.35 in a clay; fixed at 0.25 unless the case sets it, e.g.
  ``[parameters.eb_theta_fc] value = 0.12``, or frees it with a prior);
- ``\alpha`` (``eb_alpha``) the Priestley–Taylor coefficient of the wet surface on the
  available energy :math:`R_n - G`, one for the window, prior 1.26 ± 0.3 on [0, 1.6];
- :math:`f_{max}` = :data:`F_MAX`: Priestley–Taylor's 1.26 s/(s+γ) passes 1 above about 31 °C
  (a sensible heat into the surface whatever its temperature, and the solver's h below would
  have no bound). The cap binds at α = 1.26 over a wet soil above about 22 °C of air (at
  α = 1.6 above about 10.5 °C): there the latent heat is 0.9 (R_n − G) whatever α, and the data
  inform α less.
- The latent heat is switched off while :math:`R_n \le 0`: the share jumps at sunrise and
  sunset (the solver's h with it, up to tenfold). The form without the switch (a dew sink at
  night) fitted 5 of 8 drying twins better in κ but stopped far off on 3 (κ +60 %, C −79 to
  −99 %; ``docs/VALIDATION.md`` section 5); the switch fitted all 8.

The linear :math:`\beta` below the field capacity is the bucket of Manabe (1969) and the
moisture limit of Barton (1979). H and the no-wind fallback are those of :mod:`.energy`. With
G the unknown flux into the surface the balance stays a linear (Robin) boundary condition, as
for :mod:`.penman`: :math:`G = R_n - H - f (R_n - G)` with :math:`H = h_H (T_s - T_a)` solves to
:math:`G = R_n + h_H (T_a - T_s) / (1 - f)`, so the law sets the solver's ``h`` to
:math:`h_H / (1 - f)`; :meth:`EnergyBalanceSoilWater.latent` gives LE from the solved G. The
available energy is :math:`R_n - G` as in Priestley and Taylor (1972): on twins whose latent
heat follows it, the form on :math:`R_n` alone (this law before 30 Nov, the one the desert's
set-out test used) missed C by 42-63 %, this one by +3 to +28 % (κ −7 to −13 %, ``benchmarks/swc_twins.py``).

Over a dry window (``\theta`` near 0) the latent heat is small whatever ``\alpha``, so the
data hardly inform it, and what they do ask of it need not be evaporation: on the SoilVUE
desert's dry 72 h window (``\theta`` 0-0.012) ``\alpha`` runs to its bound 1.6 from every
start, in this form and in the form on :math:`R_n` alone (in-sample RMSE 0.335 and 0.322 degC
against 0.363 with no latent heat; ``docs/VALIDATION.md`` section 5): a small sink shaped by
the falling water content, not evaporation the data inform. Fix it there, or read its
estimate as uninformed. A forecast needs the water content of the day it forecasts, as it needs
the net radiation and the air temperature: it is read from the record, not predicted (the rain
is not used). The water content must have no gap in the window; a value given in % (largest
value above 1.5) is refused by the reader.
"""

from __future__ import annotations

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal
from ..registry import register_extension
from .energy import EnergyBalanceWindow
from .surface import priestley_taylor_weight

#: the largest share of the available energy R_n - G that leaves as latent heat (module doc)
F_MAX = 0.9


def soil_water(meas) -> np.ndarray | None:
    """The top soil's water content (n_obs,), m3 m-3, of ``meas``; None without it or with a
    gap (the law needs one at every time)."""
    theta = getattr(meas, "extras", {}).get("SWC")
    if theta is None:
        return None
    theta = np.asarray(theta, float)
    return theta if bool(np.all(np.isfinite(theta))) else None


@register_extension
class EnergyBalanceSoilWater(EnergyBalanceWindow):
    """Surface energy balance ``G = R_n - H - LE`` with LE limited by the measured top-soil
    water content (module doc)."""

    name = "energy_balance_swc"
    hint = ("the net radiation does not all enter the ground: sensible heat, and latent heat "
            "while the top soil holds water (its measured water content), leave the surface")
    latent_form = "Priestley–Taylor on R_n − G limited by the measured top-soil water content"

    def parameters(self, meas):
        if soil_water(meas) is None:
            raise ValueError(f"{self.name} needs the top soil's water content without gaps: an "
                             "'SWC' column (m3 m-3) in the case CSV or the [data] extras CSV "
                             "(e.g. [data.columns] \"SWC_5cm\" = \"SWC\")")
        h = [p for p in super().parameters(meas) if not p.name.startswith("eb_alpha")]
        return [*h,
                Parameter("eb_alpha", 0.0, 0.0, 1.6, prior=TruncatedNormal(1.26, 0.3, 0.0, 1.6),
                          unit="-", description="Priestley-Taylor coefficient of the wet "
                          "surface on R_n - G"),
                Parameter("eb_theta_fc", 0.25, 0.02, 0.6, vary=False, unit="m3 m-3",
                          prior=TruncatedNormal(0.25, 0.1, 0.02, 0.6),
                          description="water content above which the surface is not short "
                          "of water")]

    def wetness(self, p, meas) -> np.ndarray:
        """beta(theta) (n_sets, n_obs) of the module doc."""
        theta = soil_water(meas)
        return np.minimum(1.0, theta[None, :] / np.asarray(p["eb_theta_fc"], float)[:, None])

    def share(self, p, meas) -> np.ndarray:
        """f (n_sets, n_obs) of the module doc: the share of R_n - G that leaves as LE."""
        day = np.asarray(meas.q_net, float) > 0.0
        f = (np.asarray(p["eb_alpha"], float)[:, None] * self.wetness(p, meas)
             * (priestley_taylor_weight(meas.T_air) * day)[None, :])
        return np.minimum(f, F_MAX)

    def latent(self, p, meas, G=None) -> np.ndarray:
        """LE (n_sets, n_obs), W m-2, given ``G``: what R_n loses at the spot besides LE and H
        (the solved heat flux into the surface, and what a shadow keeps off it)."""
        return self.share(p, meas) * (np.asarray(meas.q_net, float)[None, :]
                                      - (0.0 if G is None else G))

    def surface(self, coeffs, p, model):
        self.set_h(coeffs, self.transfer(p, model.meas) / (1.0 - self.share(p, model.meas)))
