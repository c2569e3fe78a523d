r"""A surface energy balance: the net radiation split into sensible, latent and ground heat.

The free h(t) of the base model is replaced by laws with few parameters (the free value per
interval is gone), so the model can predict a day it has not seen from its forcing:

.. math::

    G = R_n - H - LE, \qquad
    H = h_H(t)\,(T_s - T_a), \qquad
    LE = \alpha_d\,\frac{s(T_a)}{s(T_a) + \gamma}\,\max(R_n, 0)

- ``R_n`` the recorded net radiation ``q_net`` (W m-2, measured at the real surface
  temperature, so the emitted long-wave is in it), ``T_a`` the air temperature, ``T_s`` the
  model's surface temperature, ``G`` the heat flux into the ground (W m-2).
- Sensible heat by a bulk transfer law, :math:`h_H = h_0 + h_1 u` with the measured wind ``u``
  (m s-1) -- the form of pvlib's Faiman model; :math:`\rho c_p C_H \approx 4`-7 J m-3 K-1 over
  short grass at 2 m. **Without a wind column** (the fallback, e.g. a desert station) the law
  has no drive to scale: :math:`h_H = h_0`, one transfer coefficient for the window, and
  ``eb_h1`` is not a parameter (a stand-in drive such as the daytime heating
  :math:`\max(R_n, 0)` was tried on the desert record: its coefficient went to its bound 0,
  the data did not ask for it).
- Latent heat in the Priestley–Taylor form with the net radiation as the available energy
  (the ground heat flux, 5-20 % of it by day over grass, is left in: ``eb_alpha`` is about
  :math:`\alpha_{PT}(1 - G/R_n)`, ~1.0-1.1 over well-watered grass, 0 over a dry surface), one
  coefficient per day of the window (24 h from its start; the surface dries or is wetted
  slowly; one parameter group ``eb_alpha``), or with ``energy_balance_window`` one coefficient
  for the whole window (fewer parameters; a forecast needs no rule for a day it has not seen).
  ``s`` is the slope of the saturation vapour pressure (Tetens), ``\gamma = 0.066`` kPa K-1.
  Over a dry soil the data may ask for no latent heat at all (the desert record's 72 h window
  runs the coefficient to its bound 0): fix it there (``[parameters.eb_alpha] value = 0.0,
  vary = false``) instead of leaving it at the bound. This form does not use the air's
  humidity: a drying surface shows as a falling ``eb_alpha`` from day to day. Where the record
  has the relative humidity, ``energy_balance_pm`` (:mod:`.penman`) puts the evaporative
  demand in (Penman–Monteith, one surface resistance a day); where it has the top soil's water
  content, ``energy_balance_swc`` (:mod:`.soil_water`) lets the latent heat follow it.

A grass or thatch layer is added by listing ``canopy`` (a skin node with heat capacity above
the soil, which the balance acts on) or ``surface_layer`` (a pure resistance: it then damps
the solver's h and q together, here ``h_H`` and ``R_n - LE``, with the forms on
:math:`R_n - G` their ``h_H / (1 - f)`` and q) with this entry (the balance's hook runs first
whatever the order listed, :attr:`~pavement_mcmc.physics.model.Model.surface_order`); the
infrared surface temperature (``[data] ir_sigma``) observes the skin. :func:`energy_partition` gives the
four fluxes a fit implies; the report and ``plot_energy_balance`` show them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal, Uniform
from ..base import Extension
from ..registry import register_extension
from .surface import priestley_taylor_weight

DAY = 86400.0


def day_index(t: np.ndarray, n_days: int | None = None) -> np.ndarray:
    """Day of the window (0, 1, ...) of each time ``t`` (s): 24 h pieces from the window start,
    the last time of a whole number of days in the last day; later times (a forecast) in the
    last day when ``n_days`` is given."""
    t = np.asarray(t, float)
    n = n_days_of(t) if n_days is None else int(n_days)
    return np.clip(np.floor(t / DAY).astype(int), 0, n - 1)


def n_days_of(t: np.ndarray) -> int:
    """Number of 24 h pieces that cover the window ``t`` (s from its start)."""
    return max(1, math.ceil(float(np.asarray(t)[-1]) / DAY - 1e-6))


@register_extension
class EnergyBalance(Extension):
    """Surface energy balance ``G = R_n - H - LE``: H by a bulk law with the wind, LE by
    Priestley–Taylor with one coefficient per day (see the module docstring)."""

    name = "energy_balance"
    hint = ("the net radiation does not all enter the ground: sensible heat (with the wind) and "
            "latent heat (evapotranspiration) leave the surface")
    replaces_h = True
    candidate = False  # it nests wind_convection and evapotranspiration: tried only when named
    signals = ("corr:q_net", "amplitude", "corr:wind", "corr:T_air-T_s")
    #: the latent heat's law in a few words (the report's caption)
    latent_form = "Priestley–Taylor on the net radiation"

    def alpha_names(self, meas) -> list[str]:
        """``eb_alpha_1 .. eb_alpha_D``, one per day of the window."""
        return [f"eb_alpha_{d + 1}" for d in range(n_days_of(meas.t))]

    def parameters(self, meas):
        q = getattr(meas, "q_net", None)
        if q is None or not np.any(np.asarray(q, float) != 0.0):
            raise ValueError(f"{self.name} needs the net radiation (a 'q_net' column, W m-2)")
        h = [Parameter("eb_h0", 4.0, 0.0, 60.0, prior=TruncatedNormal(4.0, 4.0), unit="W m-2 K-1",
                       description="still-air sensible heat transfer coefficient"
                       if meas.wind is not None else
                       "sensible heat transfer coefficient (no wind column: one for the window)")]
        if meas.wind is not None:
            h.append(Parameter("eb_h1", 5.0, 0.0, 40.0, prior=TruncatedNormal(5.0, 3.0),
                               unit="J m-3 K-1", description="wind sensitivity of the sensible "
                               "heat transfer coefficient"))
        names = self.alpha_names(meas)
        # one group for the daily coefficients: `[parameters.eb_alpha]` sets them all, and a
        # forecast keeps the last fitted day's for the days after it (criticism/forecast.py)
        group = "" if names == ["eb_alpha"] else "eb_alpha"
        return [*h, *[Parameter(n, 0.5, 0.0, 1.6, prior=Uniform(0.0, 1.6), unit="-",
                                description="Priestley-Taylor coefficient on R_n, "
                                + (f"day {d + 1}" if group else "the window"), group=group)
                      for d, n in enumerate(names)]]

    def start_values(self, meas, base):
        if meas.wind is None:
            return [{"eb_h0": 3.0}, {"eb_h0": 10.0}]
        return [{"eb_h0": 3.0, "eb_h1": 3.0}, {"eb_h0": 8.0, "eb_h1": 6.0}]

    def transfer(self, p, meas) -> np.ndarray:
        """Sensible heat transfer coefficient h_H at each observation time (n_sets, n_obs)."""
        h0 = np.broadcast_to(p["eb_h0"][:, None], (p["eb_h0"].size, meas.t.size))
        if meas.wind is None:
            return h0.copy()
        return h0 + p["eb_h1"][:, None] * np.asarray(meas.wind, float)[None, :]

    def latent(self, p, meas, G=None) -> np.ndarray:
        """Latent heat flux LE at each observation time (n_sets, n_obs), W m-2 (``G``, the
        solved flux into the surface, is not needed by this form)."""
        names = self.alpha_names(meas)
        alpha = np.stack([np.asarray(p[n], float) for n in names], axis=1)
        a_t = alpha[:, day_index(meas.t, len(names))]
        avail = priestley_taylor_weight(meas.T_air) * np.clip(meas.q_net, 0.0, None)
        return a_t * avail[None, :]

    @staticmethod
    def set_h(coeffs, h: np.ndarray) -> None:
        """The solver's h per interval from ``h`` (n_sets, n_obs) at the observation times (the
        mean of each interval's ends)."""
        coeffs.h = 0.5 * (h[:, :-1] + h[:, 1:])

    def surface(self, coeffs, p, model):
        self.set_h(coeffs, self.transfer(p, model.meas))
        coeffs.q -= self.latent(p, model.meas)



@register_extension
class EnergyBalanceWindow(EnergyBalance):
    """The surface energy balance with one Priestley–Taylor coefficient ``eb_alpha`` for the
    whole window (a surface whose wetness does not change within it; module doc)."""

    name = "energy_balance_window"

    def alpha_names(self, meas) -> list[str]:
        return ["eb_alpha"]


@dataclass(frozen=True)
class Partition:
    """The surface energy balance a fit implies, W m-2, each (n_sets, n_obs).

    ``Rn`` the recorded net radiation (the same for every set), ``H`` sensible and ``LE`` latent
    heat leaving the surface, ``G`` the heat flux into the soil (``Rn = H + LE + G + off``; with
    a ``surface_layer`` its storage is neglected as in the model; with a ``canopy`` ``G`` enters
    the canopy skin: the canopy's storage and the soil's flux together). ``off``: what other
    surface terms take off the spot (a ``shading`` shadow, a ``radiation_factor``, a sink after
    rain; zero without them).
    """

    t: np.ndarray
    Rn: np.ndarray
    H: np.ndarray
    LE: np.ndarray
    G: np.ndarray
    off: np.ndarray | None = None

    def midday(self) -> dict[str, np.ndarray]:
        """Ratios of sums over the midday rows (``R_n`` above half its maximum), one per set:
        ``bowen`` H/LE, ``G_Rn`` G/R_n, ``LE_Rn`` LE/R_n, ``H_Rn`` H/R_n."""
        q = self.Rn[0]
        rows = q > 0.5 * max(float(q.max()), 1e-9)
        s = {k: getattr(self, k)[:, rows].sum(axis=1) for k in ("Rn", "H", "LE", "G")}
        with np.errstate(divide="ignore", invalid="ignore"):
            out = {"bowen": s["H"] / s["LE"], "G_Rn": s["G"] / s["Rn"],
                   "LE_Rn": s["LE"] / s["Rn"], "H_Rn": s["H"] / s["Rn"]}
        if self.off is not None and np.max(np.abs(self.off)) > 1e-6 * np.max(np.abs(self.Rn)):
            out["off_Rn"] = self.off[:, rows].sum(axis=1) / s["Rn"]
        return out


    def summary(self, level: float = 95.0) -> dict[str, tuple[float, float, float]]:
        """Midday ratios (:meth:`midday`) over the sets: ``{name: (median, lo, hi)}`` with the
        central ``level`` % interval."""
        q = [50.0, 50 - level / 2, 50 + level / 2]
        with np.errstate(invalid="ignore"):  # H/LE is infinite without latent heat
            return {k: tuple(float(x) for x in np.nanpercentile(v, q))
                    for k, v in self.midday().items()}

    def summary_text(self, level: float = 95.0) -> str:
        """The midday partition in one line a micrometeorologist reads."""
        s = self.summary(level)
        band = self.H.shape[0] > 1
        parts = [f"{MIDDAY_NAMES[k]} {m:.2f}" + (f" [{lo:.2f}, {hi:.2f}]" if band else "")
                 if np.isfinite(m) else f"{MIDDAY_NAMES[k]} undefined (no latent heat)"
                 for k, (m, lo, hi) in s.items()]
        return ("surface energy balance at midday (R_n above half its maximum"
                + (f"; {level:g} % intervals" if band else "") + "): " + ", ".join(parts))


#: the midday ratios of :meth:`Partition.midday`, as a table or a line names them
MIDDAY_NAMES = {"bowen": "Bowen ratio H/LE", "G_Rn": "G/Rn", "LE_Rn": "LE/Rn", "H_Rn": "H/Rn",
                "off_Rn": "taken off by other surface terms/Rn"}


def other_terms(model, p: dict[str, np.ndarray], law) -> np.ndarray:
    """What the surface terms besides the balance ``law`` and a layer over the soil take off
    the spot, W m-2 (n_sets, n_obs): a shadow, a radiation factor, a sink after rain. Their
    hooks only add to q (:attr:`~pavement_mcmc.physics.model.Model.surface_order`), so they
    are run on a zero q; H is the rest of the skin's balance (with a surface_layer, coeffs.q -
    G is not the law's H)."""
    n_sets = np.asarray(p["kappa"]).size
    acc = SimpleNamespace(h=np.zeros((n_sets, model.meas.n_obs - 1)),
                          q=np.zeros((n_sets, model.meas.n_obs)))
    for e in model.surface_order:
        if e is not law and not e.over_soil:
            e.surface(acc, p, model)
    return -acc.q


def energy_partition(model, p: dict[str, np.ndarray]) -> Partition:
    """H, LE and G a model with :class:`EnergyBalance` implies at parameter sets ``p``
    (``{name: (n_sets,)}``): G from the solved surface flux, LE from the law, H the rest."""
    ext = next((e for e in model.extensions if isinstance(e, EnergyBalance)), None)
    if ext is None:
        raise ValueError("the model has no energy_balance extension: "
                         f"{', '.join(e.name for e in model.extensions) or 'none'}")
    coeffs = model.coefficients(p)
    G = model.surface_flux(model.solve(p), coeffs)
    Rn = np.broadcast_to(np.asarray(model.meas.q_net, float), G.shape)
    off = other_terms(model, p, ext)
    # a law on the available energy (Penman-Monteith, the soil-water form) evaporates on what
    # reaches the spot, R_n - off - G: the "G" it is given is what R_n loses besides LE and H
    LE = ext.latent(p, model.meas, G + off)
    return Partition(model.meas.t, Rn, Rn - off - LE - G, LE, G, off)
