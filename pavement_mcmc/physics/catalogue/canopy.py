r"""A canopy (grass, thatch, litter or mulch) above the soil that stores heat: the surface energy
balance acts on its skin, a resistance joins it to the soil.

The skin is a lumped node of areal heat capacity :math:`c_k` joined to the soil surface by the
layer's thermal resistance :math:`R`:

.. math::

    c_k \frac{dT_k}{dt} = \underbrace{R_n - LE - H}_{\text{the surface balance}}
      - \frac{T_k - T_0}{R}, \qquad G_\mathrm{soil} = \frac{T_k - T_0}{R},

with :math:`T_k` the skin (what an infrared thermometer sees), :math:`T_0` the soil surface.
It is built into the solver's column, which stays tridiagonal: the model puts a skin node
:data:`SKIN` (1 mm) above the case's grid (:meth:`~pavement_mcmc.solver.Grid.with_skin`), its
first cell is the layer (conductivity :math:`\Delta x_0 / R`), the skin's heat capacity
:math:`2 c_k / \Delta x_0` (its control volume is half the first cell). The soil surface is the
second node; sensor and plate depths count from it, as they are measured, on any grid.

Parameters (SI): ``R_canopy`` in m2 K W-1 (grass and thatch of 1-5 cm: about 0.05-0.5;
bounds 0.005-2), ``c_canopy`` in J m-2 K-1 (water and biomass of a grass sward and its thatch:
about 2-20 kJ m-2 K-1, 1 kg m-2 of water is 4.2 kJ m-2 K-1; bounds 100-1e5). With ``c_canopy``
small it is ``surface_layer`` (a pure resistance); a model takes one of the two. Without
``energy_balance`` the base model's surface balance, h(t) (T_air - T_k) + q, acts on the skin:
as such ``diagnose`` tries it (it finds the campaign's 1.5 cm thatch layers, docs/VALIDATION.md
section 4). With ``energy_balance`` the H and LE laws act on the skin, and the IR stream
(``[data] ir_sigma``) observes it, which pins ``R_canopy`` and the H law.
"""

from __future__ import annotations

from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal
from ..base import Extension
from ..registry import register_extension

#: thickness (m) of the skin's cell above the soil: thin, so that its conductivity dx / R and
#: capacity 2 c / dx stand for the lumped resistance and storage
SKIN = 0.001


@register_extension
class Canopy(Extension):
    """A heat-storing canopy/thatch over the soil: a skin node 1 mm above it (module doc)."""

    name = "canopy"
    hint = ("the shallowest sensor's daily wave is damped and late against the net radiation, "
            "and the infrared surface is far warmer by day than the soil: a canopy or thatch "
            "stores heat and insulates the soil")
    signals = ("phase_lag", "amplitude", "corr:q_net")
    reads = ("kappa", "C")
    skin_node = SKIN

    def parameters(self, meas):
        return [
            Parameter("R_canopy", 0.2, 0.005, 2.0, prior=TruncatedNormal(0.2, 0.3, 0.005, 2.0),
                      unit="m2 K W-1", description="thermal resistance of the canopy/thatch layer"),
            Parameter("c_canopy", 5e3, 100.0, 1e5, prior=TruncatedNormal(5e3, 1e4, 100.0, 1e5),
                      unit="J m-2 K-1", description="areal heat capacity of the canopy skin"),
        ]

    def start_values(self, meas, base):
        return [{"R_canopy": 0.1, "c_canopy": 2e3}, {"R_canopy": 0.4, "c_canopy": 1.5e4}]

    def material(self, coeffs, p, model):
        x = model.grid.x
        dx0, dx1 = model.grid.soil_top, float(x[2] - x[1])
        coeffs.kappa = coeffs.kappa.copy()
        coeffs.C = coeffs.C.copy()
        coeffs.kappa[:, 0] = dx0 / p["R_canopy"]
        coeffs.C[:, 0] = 2.0 * p["c_canopy"] / dx0
        # the soil top's control volume reaches half the skin cell up: only its soil half
        # (dx1 / 2) stores soil heat, the canopy's storage is all on the skin
        coeffs.C[:, 1] *= dx1 / (dx0 + dx1)
