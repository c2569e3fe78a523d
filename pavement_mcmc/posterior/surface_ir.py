r"""The infrared surface temperature as an observation stream (``T_surf_IR``, degC).

An infrared thermometer (or a pyrgeometer's upwelling long-wave, :math:`T = (L_\uparrow /
\varepsilon\sigma_{SB})^{1/4}`) reads the radiometric temperature of the surface. The model's
surface temperature is its skin (:mod:`pavement_mcmc.physics.skin`): the top node where the
surface energy balance acts on the soil, or the canopy skin above a ``surface_layer``
(:math:`T_0 + R\,G`), so

.. math:: T_\mathrm{IR}(t) = f\,T_k(t) + (1 - f)\,T_b(t) + \delta + e(t),\qquad
          e \sim N(0, \sigma_\mathrm{IR}^2),

with :math:`\delta` = ``ir_offset`` (degC), a nuisance parameter with a Gaussian prior of sd
:data:`OFFSET_SD`: an emissivity error :math:`\Delta\varepsilon` shifts a radiometric
temperature by about :math:`-T\,\Delta\varepsilon / 4\varepsilon` (0.7 K per 0.01 near 290 K),
and a canopy's skin is not the soil's top. Its value and bounds can be set in
``[parameters.ir_offset]`` (``vary = false`` fixes it). :math:`f` = ``ir_view`` is the weight
of the modelled skin in the reading, :math:`T_b` what the rest of it reads:

- under a layer over the soil (``canopy``, ``surface_layer``), the soil surface below the
  layer, :math:`T_b = T_0`: a radiometer looks down into a sward or thatch, and the deeper
  leaves, stems and litter it sees sit near the soil's temperature, far from the sunlit top's.
  :math:`f` is then a weight, not the share of the view stopped in the layer: on twins whose
  thermometer looks into a resolved thatch (Beer's law, radiances averaged; 60 % and 80 % of
  the view stopped in it) the MAP weighs the skin 0.35-0.37 and 0.51-0.54 and finds kappa and C
  within 15 %, where held at 1 they come out 1.7-2.3 times the truth
  (``benchmarks/ir_view_twins.py``, docs/VALIDATION.md section 5). It does not describe a sparse
  cover with sunlit bare gaps (each with its own energy balance): on twins with 40 % and 20 %
  bare patches the weight stays at 0.91-0.92 and 0.96-0.99, and kappa and C hold within 20 %
  free or at 1. It is
  linear in the temperatures, where radiances add as :math:`T^4`: 0.1 K for a canopy and soil
  10 K apart at equal weights, 0.4 K at 20 K apart and :math:`f` 0.74 (near the Göttingen
  grass's midday, against its sd of 0.5). Over ``surface_layer`` the reading is
  :math:`T_0 + f R G`: the IR alone weighs only :math:`f R`, the sensors' damping sets
  :math:`R`.
- without a layer the modelled surface is the soil (bare soil between desert shrubs, a sparse
  crop), and the rest (leaves near air temperature) reads :math:`T_b = T_a`.

It is fixed at 1 (the reading all skin) unless ``[parameters.ir_view] vary = true``; prior
N(1, 0.3) on 0.1-1.5 (above 1: an emissivity error that scales the contrast with
:math:`T_b`).

**A lead** (``ir_lead``, minutes, fixed at 0 unless ``[parameters.ir_lead] vary = true``; prior
N(0, 60 min) on 0-120). Under ``canopy`` the model's skin is a node that stores heat: on the
Göttingen grass 22-35 kJ m-2 K-1, several times what a sward's leaves hold, so thatch, litter,
root mat or top soil too. A radiometer sees the top leaves, which store almost none. The node
relaxes towards the temperature a surface without storage would have under the same exchange,
:math:`T_k + \tau\,dT_k/dt` with :math:`\tau = c/K` (:math:`K` = the node's transfer to the air
and to the soil, :math:`h_H + 1/R`), and that is what the IR reads in place of :math:`T_k`
above, at the record's rows as the inverse of the node's implicit step,
:math:`T_k(t_i) + \tau\,(T_k(t_i) - T_k(t_{i-1}))/(t_i - t_{i-1})`. Two forms:

- ``[data] ir_storage_free = true`` (needs ``canopy``): :math:`\tau = c_{canopy}/(h + 1/R_{canopy})`
  over each interval, with the balance's own transfer coefficient :math:`h`: no parameter.
  ``runs/grass_energy.toml`` uses it (its ``hmc`` fit 67-107 s).
- ``[parameters.ir_lead] vary = true``: :math:`\tau` a free parameter (minutes). The fits find
  it at 0.8-1.0 of the node's relaxation time (the grass 32 min against 40; twins of a
  heat-storing thatch read at its top 23.6-26.0 against 24.9-28.0, ``benchmarks/ir_lead_twins.py``,
  ``benchmarks/grass_ir_timing.py``), along a ridge with ``c_canopy`` (the grass's ``hmc`` fit
  855-1236 s).

The balance still acts on the node (H and LE are the node's, not the leaves': the midday Bowen
ratio and G/Rn depend on that shortcut). On the grass record the free lead takes the IR misfit
from 1.24 to 1.10 °C and the next-day forecast of the buried sensors from 0.230 to 0.211 °C
(storage-free: 1.21 and 0.207); on the twins it is found with the thatch's heat capacity (held
at 0 the fit finds a third of it) and κ and C stay 23-40 % off (5-33 % with the weight free too;
storage-free and the weight free 2-22 %); over a thin thatch no lead is found
(docs/VALIDATION.md section 5).

Column convention: ``T_surf_IR`` in the case CSV or in the ``[data] extras`` CSV
(:mod:`pavement_mcmc.data.extras`); switched on by ``[data] ir_sigma`` (the sd of one reading,
degC). A measured top is refused: its top node is a buried sensor, not the surface.
"""

from __future__ import annotations

import numpy as np

from ..parameters import Parameter
from ..parameters.priors import TruncatedNormal
from ..physics.skin import skin_temperature, skin_vjp
from .observations import Observation

__all__ = ["COLUMN", "OFFSET_SD", "PARAMETER_NAMES", "SurfaceIR"]

#: the column of the stream (:data:`pavement_mcmc.data.extras.EXTRA_ROLES`)
COLUMN = "T_surf_IR"
#: prior sd of the offset, degC
OFFSET_SD = 2.0
#: the stream's own parameters (a case may set them in ``[parameters]``)
PARAMETER_NAMES = ("ir_offset", "ir_view", "ir_lead")


class SurfaceIR(Observation):
    """The infrared surface temperature: the model's skin plus ``ir_offset``, sd ``sigma``."""

    name = "surface_ir"
    labels = ["IR"]
    quantity, unit = "infrared surface temperature", "°C"

    def __init__(self, meas, sigma: float, storage_free: bool = False):
        if COLUMN not in meas.extras:
            raise ValueError(f"ir_sigma is set but the data have no {COLUMN!r} column (in the "
                             "case CSV or the [data] extras CSV)")
        if meas.T_top is not None:
            raise ValueError(f"{COLUMN} needs the surface energy balance at the top (model.top = "
                             "'surface'): with a measured top the top node is a buried sensor")
        if not sigma > 0:
            raise ValueError(f"ir_sigma must be > 0, got {sigma!r}")
        self.sigma = float(sigma)
        self.storage_free = bool(storage_free)
        self.data = np.asarray(meas.extras[COLUMN], float)[1:, None]  # (n_obs - 1, 1)
        n_gap = int(np.sum(~np.isfinite(meas.extras[COLUMN])))
        if n_gap:
            raise ValueError(f"{COLUMN} has {n_gap} missing values in the case's window that "
                             "max_gap_fill cannot fill (at its edge or too long); narrow "
                             "window_hours or raise max_gap_fill")

    def on(self, meas) -> SurfaceIR:
        """The same stream (its sd and its reading's form) on other rows ``meas`` (a forecast's
        training rows)."""
        return SurfaceIR(meas, self.sigma, storage_free=self.storage_free)

    def parameters(self) -> list:
        return [Parameter("ir_offset", 0.0, -20.0, 20.0,
                          prior=TruncatedNormal(0.0, OFFSET_SD, -20.0, 20.0), unit="degC",
                          description="infrared surface temperature minus the model's surface"),
                Parameter("ir_view", 1.0, 0.1, 1.5, prior=TruncatedNormal(1.0, 0.3, 0.1, 1.5),
                          unit="-", vary=False,
                          description="weight of the modelled skin in the IR reading (the rest: "
                                      "the soil under a layer, else the air)"),
                *([] if self.storage_free else [Parameter(
                    "ir_lead", 0.0, 0.0, 120.0, prior=TruncatedNormal(0.0, 60.0, 0.0, 120.0),
                    unit="min", vary=False,
                    description="how far the surface the IR sees leads the model's skin (a "
                                "first-order lag's time constant)")])]

    def predict(self, model, T_nodes, coeffs, p):
        T = _lead(skin_temperature(model, T_nodes, coeffs, p), model.meas.t,
                  self._tau(model, coeffs, p))[0]
        f = np.asarray(p["ir_view"], float)[:, None]
        Tb = _background(model, T_nodes)[0]
        return (Tb + f * (T - Tb))[..., None] + np.asarray(p["ir_offset"], float)[:, None, None]

    def whiten(self, r):
        return r.reshape(*r.shape[:-2], -1) / self.sigma

    @property
    def logdet(self) -> float:
        return self.size * np.log(self.sigma**2)

    def marginal_sd(self):
        return np.full(self.data.shape, self.sigma)

    def vjp(self, model, pred, r, z, ok, T_nodes, coeffs, p, gT):
        g = -np.where(ok[:, None, None], r, 0.0)[..., 0] / self.sigma**2  # (n_sets, n_obs - 1)
        gT = np.zeros(T_nodes.shape) if gT is None else gT
        g_skin = np.concatenate([np.zeros((g.shape[0], 1)), g], axis=1)
        f = np.asarray(p["ir_view"], float)[:, None]
        tau = self._tau(model, coeffs, p)
        T, rate, a = _lead(skin_temperature(model, T_nodes, coeffs, p), model.meas.t, tau)
        g_lead = f * g_skin  # the cotangent of the led skin; back through the lead to the skin
        g_node = g_lead * (1.0 + a)
        g_node[:, :-1] -= (g_lead * a)[:, 1:]
        g_top, direct = skin_vjp(model, g_node, T_nodes, coeffs, p)
        gT[..., 0] += g_top
        Tb, node = _background(model, T_nodes)
        if node is not None:  # the soil surface under the layer
            gT[..., node] += (1.0 - f) * g_skin
        direct["ir_offset"] = np.sum(g, axis=1)
        direct["ir_view"] = np.sum(g_skin * (T - Tb), axis=1)
        if self.storage_free:  # tau = c / (h + 1/R): through c_canopy, R_canopy and h
            c, R = _canopy(p)
            K = c / tau[:, 1:]
            gs = (g_lead * rate)[:, 1:]
            direct["c_canopy"] = direct.get("c_canopy", 0.0) + np.sum(gs / K, axis=1)
            direct["R_canopy"] = (direct.get("R_canopy", 0.0)
                                  + np.sum(gs * c / (K * K * R * R), axis=1))
            direct["h"] = direct.get("h", 0.0) - gs * c / (K * K)
        else:
            direct["ir_lead"] = 60.0 * np.sum(g_lead * rate, axis=1)
        return gT, direct

    def _tau(self, model, coeffs, p) -> np.ndarray:
        """The lead at each row (n_sets, n_obs), s: ``ir_lead`` minutes, or with
        ``storage_free`` the canopy node's relaxation time ``c / (h + 1/R)`` over the interval
        ending at the row (row 0: unused)."""
        n = coeffs.h.shape[0]
        if not self.storage_free:
            lead = np.asarray(p["ir_lead"], float) if "ir_lead" in p else np.zeros(n)
            return np.broadcast_to(60.0 * lead[:, None], (n, model.meas.t.size))
        c, R = _canopy(p)
        K = coeffs.h + 1.0 / R
        return c / np.concatenate([K[:, :1], K], axis=1)


def _lead(T: np.ndarray, t: np.ndarray, tau: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(T + tau dT/dt, dT/dt, tau / dt)`` of the skin ``T`` (n_sets, n_obs) at the rows ``t``
    (s), ``tau`` (n_sets, n_obs) s; dT/dt the backward difference, 0 at the first row (the
    inverse of a first-order lag's implicit step, module doc)."""
    dt = np.diff(np.asarray(t, float))
    rate = np.zeros(T.shape)
    rate[:, 1:] = np.diff(T, axis=1) / dt
    a = np.zeros(T.shape)
    a[:, 1:] = tau[:, 1:] / dt
    return T + tau * rate, rate, a


def _canopy(p) -> tuple[np.ndarray, np.ndarray]:
    """``(c_canopy, R_canopy)`` as (n_sets, 1) columns (``build_problem`` refuses
    ``ir_storage_free`` without a ``canopy``)."""
    return (np.asarray(p["c_canopy"], float)[:, None], np.asarray(p["R_canopy"], float)[:, None])


def _background(model, T_nodes: np.ndarray) -> tuple[np.ndarray, int | None]:
    """What the footprint's part outside the skin reads (n_sets, n_obs), degC, and the node it
    is (None: the air): under a layer over the soil, the soil surface below it (the node under
    a skin node, else the top node); without one, the air temperature (module doc)."""
    if any(e.over_soil for e in model.extensions):
        node = 1 if model.grid.soil_top else 0
        return T_nodes[..., node], node
    return np.broadcast_to(model.forcing.T_air[None, :], T_nodes.shape[:-1]), None
