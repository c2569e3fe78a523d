"""The log-posterior: priors + independent Gaussian likelihood over the sensors, vectorised.

``LogPosterior(theta)`` takes the free parameters of many sets at once, ``(n_sets, n_free)``,
and returns ``(log_post (n_sets,), blobs (n_sets, n_sensors))`` where the blobs are the RMSE of
each sensor (degC). Sets outside the bounds or prior support get ``-inf`` (and ``inf`` blobs)
without being solved, without warnings and without NaN. There is no Python loop over sets.

The first observation row is the initial condition (the solver starts from the sensors' values
interpolated at t = 0), so it carries no information and is left out of the likelihood.

With ``input_noise`` set (:mod:`pavement_mcmc.input_noise`), the noise of the bottom boundary
and initial temperatures is integrated out: the residuals are whitened by the resulting
covariance instead of divided by sigma.
"""

from __future__ import annotations

import numpy as np

from .parameters import ParameterSpace
from .physics.model import Model

_LOG_2PI = np.log(2.0 * np.pi)


class LogPosterior:
    """Log-posterior of a model given its measurements.

    Parameters
    ----------
    model : the forward model (its ``meas`` are the data).
    space : the parameter space (free parameters, bounds, priors, joint priors).
    """

    def __init__(self, model: Model, space: ParameterSpace):
        self.model = model
        self.space = space
        self.meas = model.meas
        self.obs = model.meas.T_obs[1:]  # (n_obs-1, n_sensors)
        self.sigma = float(model.meas.sigma)
        self.n_data = self.obs.size
        self.input_noise = None  # an InputNoise, or None: boundary and initial data exact

    @property
    def names(self) -> list[str]:
        return self.space.free

    @property
    def blob_names(self) -> list[str]:
        return [f"rmse_{lab}" for lab in self.meas.sensor_labels]

    @property
    def ndim(self) -> int:
        return len(self.space.free)

    def predict(self, theta: np.ndarray) -> np.ndarray:
        """Predicted sensor temperatures, (n_sets, n_obs, n_sensors), degC."""
        return self.model.predict(self.space.expand(theta))

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """Predicted minus observed temperatures, (n_sets, n_obs - 1, n_sensors), degC."""
        return self.predict(theta)[:, 1:, :] - self.obs

    def standardized_residuals(self, r: np.ndarray) -> np.ndarray:
        """Whitened residuals (..., n_data) of residual arrays (..., n_obs-1, n_sensors):
        ``r / sigma``, or ``Sigma^(-1/2) r`` with noisy inputs."""
        flat = r.reshape(*r.shape[:-2], -1)
        if self.input_noise is None:
            return flat / self.sigma
        return self.input_noise.whiten(flat)

    def log_likelihood_from_residuals(self, r: np.ndarray) -> np.ndarray:
        """Gaussian log-likelihood of residual arrays (..., n_obs-1, n_sensors)."""
        z2 = np.sum(self.standardized_residuals(r) ** 2, axis=-1)
        logdet = (self.n_data * np.log(self.sigma**2) if self.input_noise is None
                  else self.input_noise.logdet)
        return -0.5 * (z2 + logdet + self.n_data * _LOG_2PI)

    def pointwise_log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Log-likelihood of each datum, (n_sets, n_obs - 1, n_sensors) (for ArviZ / LOO).

        With noisy inputs, each datum's marginal density (its sd includes the inputs' share)."""
        r = self.residuals(theta)
        sd = self.sigma if self.input_noise is None else self.input_noise.marginal_sd.reshape(r.shape[1:])
        return -0.5 * (r / sd) ** 2 - np.log(sd) - 0.5 * _LOG_2PI

    def __call__(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        theta = np.atleast_2d(np.asarray(theta, float))
        n_sets = theta.shape[0]
        lp = self.space.log_prior(theta)
        ok = np.isfinite(lp)
        out = np.full(n_sets, -np.inf)
        blobs = np.full((n_sets, self.meas.n_sensors), np.inf)
        if ok.any():
            with np.errstate(all="ignore"):
                r = self.residuals(theta[ok])
                ll = self.log_likelihood_from_residuals(r)
                rmse = np.sqrt(np.mean(r * r, axis=1))
            good = np.isfinite(ll)
            vals = np.where(good, lp[ok] + ll, -np.inf)
            out[ok] = vals
            blobs[ok] = np.where(good[:, None], rmse, np.inf)
        return out, blobs

    def log_prob(self, theta: np.ndarray) -> np.ndarray:
        """Log-posterior only, (n_sets,)."""
        return self(theta)[0]
