"""Leave-one-sensor-out (LOSO) predictive checks.

For each observed sensor ``k``: drop it from the data (also from the initial profile), refit the
model by MAP on the other sensors, predict sensor ``k`` from the refitted model (its sensor-specific
parameters, e.g. ``bias_k`` or ``dz_k``, cannot be learnt and stay at their null value 0) and
score the held-out series. Holding out a whole series keeps the test data's time correlation
out of the training data (a random hold-out of rows would leak it through the neighbours); what
remains shared are the forcing errors common to every sensor.

The score is the Gaussian log predictive density per held-out datum with the plug-in sd of
the posterior's likelihood (``sigma``, or each datum's marginal sd when the inputs' noise is
integrated out) and the RMSE of the held-out predictions (parameter uncertainty is ignored: a
MAP refit per fold). Each fold's refit uses the kept sensors' block of the same likelihood.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..parameters import ParameterSpace
from ..physics import Model
from ..physics.observe import interpolate, interpolation_weights
from ..posterior import LogPosterior, Problem
from ..posterior.observations import Temperatures, with_parameters
from .fitting import refit

_LOG_2PI = np.log(2 * np.pi)


@dataclass
class HoldOut:
    """LOSO result.

    Attributes
    ----------
    labels : held-out sensor labels.
    rmse : (n_sensors,) RMSE of each held-out sensor's prediction, degC.
    lpd : mean log predictive density per held-out datum (plug-in Gaussian).
    lpd_sensors : (n_sensors,) the same for each fold (its held-out sensor's data alone);
        ``lpd`` is their mean (every sensor has as many data).
    """

    labels: list[str]
    rmse: np.ndarray
    lpd: float
    lpd_sensors: np.ndarray | None = None

    def carried_by(self, other: HoldOut) -> tuple[str, float] | None:
        """The fold that carries most of the change of :attr:`lpd` from ``other`` (the same
        sensors) and its share of that change; None when the change is nil or unknown."""
        if self.lpd_sensors is None or other.lpd_sensors is None or self.labels != other.labels:
            return None
        d = (self.lpd_sensors - other.lpd_sensors) / len(self.labels)
        total = float(np.sum(d))
        if total == 0.0:
            return None
        k = int(np.argmax(d * np.sign(total)))
        return self.labels[k], float(d[k] / total)

    def change_from(self, other: HoldOut) -> str | None:
        """A sentence on :attr:`lpd`'s change from ``other`` and the fold that carries it
        (:meth:`carried_by`); None when there is none. When the other folds move the other way
        the fold's part exceeds the change: both parts are given instead of a share over 100 %."""
        carried = self.carried_by(other)
        if carried is None:
            return None
        lab, share = carried
        total = self.lpd - other.lpd
        if share <= 1.0:
            return f"LOSO lpd {total:+.3f}, {100 * share:.0f} % of it from the fold that holds out {lab}"
        part = share * total
        return (f"LOSO lpd {total:+.3f}: the fold that holds out {lab} {part:+.3f}, the other "
                f"folds {total - part:+.3f} together")

    @property
    def rmse_all(self) -> float:
        return float(np.sqrt(np.mean(self.rmse**2)))

    def to_dict(self) -> dict:
        return {
            "method": "leave-one-sensor-out, MAP refit per fold",
            "rmse": dict(zip(self.labels, self.rmse.tolist(), strict=True)),
            "rmse_all": self.rmse_all,
            "lpd_per_datum": self.lpd,
            "lpd_per_datum_by_sensor": (None if self.lpd_sensors is None else
                                        dict(zip(self.labels, self.lpd_sensors.tolist(), strict=True))),
        }


def subproblem(problem, keep: np.ndarray, fixed: dict[str, float] | None = None):
    """The problem restricted to the observed sensors ``keep`` (indices), same priors; the
    parameters named in ``fixed`` held at the given values."""
    meas = problem.meas
    sub = replace(meas, depths=meas.depths[keep], T_obs=meas.T_obs[:, keep])
    m = problem.model
    model = Model(sub, m.grid, m.h_basis, m.extensions, scheme=m.scheme, gamma0=m.gamma0,
                  plates=m.plates)
    streams = [Temperatures(sub), *problem.posterior.streams[1:]]  # plates, ...: unchanged
    defaults = with_parameters(model.parameter_space(), streams)
    params = [problem.space[n] if n in problem.space else p for n, p in defaults.params.items()]
    fixed = fixed or {}
    params = [replace(p, value=fixed[p.name], vary=False) if p.name in fixed else p
              for p in params]
    space = ParameterSpace(params, defaults.joint_priors)
    post = LogPosterior(model, space, streams=streams)
    if problem.posterior.input_noise is not None:  # the kept sensors' block of the covariance
        post.input_noise = problem.posterior.input_noise.subset(_rows(meas, keep))
    return Problem(problem.cfg, model, space, post, problem.input_ref)


def _folds(problem, start, hold: dict[str, float] | None = None):
    """Each fold's held-out sensor ``k``, its refitted subproblem (the other sensors, the
    parameters in ``hold`` held), its MAP fit from ``start`` and the node temperatures it
    predicts (k not in the start profile); a ValueError with fewer than two observed sensors
    (a fold would keep none)."""
    meas = problem.meas
    n = meas.n_sensors
    if n < 2:
        raise ValueError(f"holding a sensor out needs at least two observed sensors; the case "
                         f"observes {n} ({', '.join(meas.sensor_labels) or 'none'})")
    for k in range(n):
        sp = subproblem(problem, np.array([i for i in range(n) if i != k]), hold)
        fit = refit(sp, start)
        yield k, sp, fit, sp.model.solve(sp.space.expand(fit.theta[None, :]))


def _rows(meas, sensors: np.ndarray) -> np.ndarray:
    """Mask of the likelihood's data rows (time-major, sensors fastest) of some sensors."""
    mask = np.zeros((meas.n_obs - 1, meas.n_sensors), bool)
    mask[:, sensors] = True
    return mask.ravel()


def leave_one_sensor_out(problem, start: dict[str, float] | None = None) -> HoldOut:
    """LOSO predictive check of ``problem`` (one MAP refit per sensor), see the module doc."""
    meas = problem.meas
    n = meas.n_sensors
    rmse = np.zeros(n)
    lp = []
    sd_all = problem.posterior.marginal_sd()  # sigma, or each datum's sd with noisy inputs
    for k, sp, _, nodes in _folds(problem, start):
        g = sp.model.grid
        i, w = interpolation_weights(g.x, meas.depths[k : k + 1] + g.soil_top)
        pred = interpolate(nodes[0], i, w)[:, 0]
        r = pred[1:] - meas.T_obs[1:, k]
        rmse[k] = float(np.sqrt(np.mean(r**2)))
        sd = sd_all[:, k]
        lp.append(-0.5 * (r / sd) ** 2 - np.log(sd) - 0.5 * _LOG_2PI)
    return HoldOut(list(meas.sensor_labels), rmse, float(np.mean(np.concatenate(lp))),
                   np.array([float(np.mean(v)) for v in lp]))


def out_of_sensor(problem, values: dict[str, float], fixed: tuple[str, ...] = ()) -> np.ndarray:
    """RMSE (degC) of each sensor's series predicted by the model refitted by MAP to the other
    sensors from ``values`` (the claim rule's out-of-sensor check, :mod:`.entries`). Unlike
    :func:`leave_one_sensor_out`, the parameters named in ``fixed`` (a per-sensor nuisance's
    offsets) are held at ``values`` in every fold, and the held-out sensor is predicted with
    its own: does the physics fitted without a sensor, given the claimed calibration of every
    sensor, predict that sensor?"""
    meas = problem.meas
    hold = {k: values[k] for k in fixed if k in values}
    rmse = np.zeros(meas.n_sensors)
    for k, _, fit, nodes in _folds(problem, values, hold):
        v = {**values, **fit.values()}  # and k's own offsets: the full fit's
        pred = problem.model.observe(nodes, {key: np.array([x]) for key, x in v.items()})[0]
        rmse[k] = float(np.sqrt(np.mean((pred[1:, k] - meas.T_obs[1:, k]) ** 2)))
    return rmse
