r"""The ground forecast: the held-out period from the measured top sensor, not from h(t).

The forcing forecast (:mod:`.forecast`) predicts every sensor from the weather alone, with the
future h(t) carried forward by a rule; on clean twins its error is 2-4 sigma even with the true
parameters, and that unknown future swamps an effect of a few tenths of a degree (issue 22,
``docs/VALIDATION.md``). The ground forecast keeps the same training fit (the MAP refit of the
window up to the origin) and predicts the held-out rows of the **deeper** sensors with the
shallowest sensor's reading as a Dirichlet top (:meth:`~pavement_mcmc.data.Measurements.
with_measured_top`): no h(t), no surface balance, only the ground (kappa, C, layers, kappa(T))
and the sensors (bias, depth) between the top sensor and the others.

What the candidate's fit says about the top sensor is used, so an error of that sensor can be
credited too: its reading minus the fitted ``bias_<top>`` is the boundary temperature, and it
sits at its nominal depth plus the fitted ``dz_<top>``. A layer interface is kept at its depth
below the surface (``d_layer`` minus the top sensor's depth; above the top sensor the whole
solved column is the lower material). Extensions that act at the surface (``hook`` ``"surface"``:
wind, evaporation, evapotranspiration, radiation factor, surface layer, energy balance) are not
in the ground model at all: this forecast cannot see them, and only the candidates of
:data:`GROUND_HOOKS` may be credited by it (:mod:`.entries`).

The gain is the forcing forecast's statistic (:func:`~.forecast.forecast_gain`) on the ground
errors: :math:`F^g_c = (n/\phi_r)\log(\mathrm{MSE}^g_r/\mathrm{MSE}^g_c)`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..physics import Extension, Model
from ..solver.grid import Grid
from .forecast import gain, split_rows
from .residuals import pooled_lag1

#: where a candidate acts (:func:`where_acts`) for the ground forecast to credit it
GROUND_HOOKS = ("material", "observe")


def where_acts(ext) -> str:
    """Where a candidate acts: ``"surface"`` (the surface balance or h), ``"material"``,
    ``"observe"``, or ``"h"`` for ``None`` (a finer h(t))."""
    if ext is None:
        return "h"
    t = type(ext)
    if t.surface is not Extension.surface or ext.replaces_h or ext.skin_node:
        return "surface"
    return "material" if t.material is not Extension.material else "observe"


@dataclass
class GroundForecast:
    """Skill of one model's ground forecast on the held-out rows of the deeper sensors.

    Attributes
    ----------
    rmse : RMSE, degC; ``rmse_sigma`` in sigma; ``rmse_sensors`` per deeper sensor.
    rho : pooled lag-1 autocorrelation of the errors.
    n : number of held-out data (rows x deeper sensors).
    """

    rmse: float
    rmse_sigma: float
    rmse_sensors: list[float]
    rho: float
    n: int

    def to_dict(self) -> dict:
        return dict(self.__dict__)


def ground_extensions(model) -> list:
    """The model's extensions that act in the ground or a sensor (:data:`GROUND_HOOKS`)."""
    return [e for e in model.extensions if where_acts(e) in GROUND_HOOKS]


def ground_model(model, values: dict[str, float]) -> tuple[Model, dict[str, np.ndarray]]:
    """The measured-top model of ``model``'s case and its parameters from ``values`` (the
    module doc: corrected top reading and depth, interface below the surface)."""
    meas = model.meas
    if model.top_measured:
        raise ValueError("the ground forecast needs a surface-driven model (its top is measured)")
    if meas.n_sensors < 2:
        raise ValueError("the ground forecast needs two sensors: the top one and one to score")
    top = meas.sensor_labels[0]
    z0 = float(meas.depths[0] + values.get(f"dz_{top}", 0.0))
    T_obs = meas.T_obs.copy()
    T_obs[:, 0] -= values.get(f"bias_{top}", 0.0)
    depths = meas.depths.copy()
    depths[0] = z0
    if np.any(depths[1:] <= z0):
        raise ValueError(f"a sensor lies at or above the top sensor's depth {z0 * 100:g} cm")
    gm = replace(meas, T_obs=T_obs, depths=depths, flux_depths=None,
                 G_obs=None).with_measured_top()
    grid = Grid.from_times(gm.bottom_depth, gm.t)
    g = Model(gm, grid, model.h_basis, ground_extensions(model), scheme=model.scheme,
              plates=False)
    space = g.parameter_space()
    vals = {n: values.get(n, space[n].value) for n in space.names}
    if "d_layer" in vals:  # from the surface to the ground model's top (the sensor)
        lo, hi = space["d_layer"].lower, space["d_layer"].upper
        vals["d_layer"] = float(np.clip(vals["d_layer"] - z0, lo, hi))
    return g, {k: np.array([float(v)]) for k, v in vals.items()}


def ground_errors(problem, values: dict[str, float], origin: float, horizon: float
                  ) -> np.ndarray:
    """Ground forecast errors (predicted - measured, (rows, deeper sensors)) of the held-out
    rows after ``origin`` hours up to ``origin + horizon``, with parameters ``values``."""
    t = problem.meas.t
    n_train = split_rows(t, origin)
    n_end = int(np.searchsorted(t, (origin + horizon) * 3600.0 + 1e-6, side="right") - 1)
    g, p = ground_model(problem.model, values)
    pred = g.predict(p)[0]
    rows = slice(n_train + 1, n_end + 1)
    return pred[rows] - g.meas.T_obs[rows]


def ground_forecast(problem, fc) -> GroundForecast:
    """The ground forecast of ``problem``'s model from the training fit of its forcing forecast
    ``fc`` (:class:`~.forecast.Forecast`, last origin)."""
    r = ground_errors(problem, fc.fits[-1].values(), fc.origins[-1], fc.horizon)
    rmse = float(np.sqrt(np.mean(r**2)))
    return GroundForecast(rmse=rmse, rmse_sigma=rmse / float(problem.meas.sigma),
                          rmse_sensors=np.sqrt(np.mean(r**2, axis=0)).tolist(),
                          rho=float(pooled_lag1(r)), n=int(r.size))


def ground_gain(base: GroundForecast, cand: GroundForecast) -> float:
    """:math:`F^g_c` (module doc)."""
    return gain(base.n, base.rho, base.rmse, cand.rmse)


def ground_forecast_or_none(problem, fc) -> GroundForecast | None:
    """:func:`ground_forecast`, or None where the model has none: one sensor, a measured top, or
    a fit that moves the top sensor to or below the next (a sensor_depth offset at its bound)."""
    try:
        return ground_forecast(problem, fc)
    except ValueError:
        return None
