"""The log-posterior: priors + independent Gaussian likelihood over the sensors, vectorised.

``LogPosterior(theta)`` takes the free parameters of many sets at once, ``(n_sets, n_free)``,
and returns ``(log_post (n_sets,), blobs (n_sets, n_sensors))`` where the blobs are the RMSE of
each sensor (degC). Sets outside the bounds or prior support get ``-inf`` (and ``inf`` blobs)
without being solved, without warnings and without NaN. There is no Python loop over sets.

The first observation row is the initial condition (the solver starts from the sensors' values
interpolated at t = 0), so it carries no information and is left out of the likelihood.

With ``input_noise`` set (:mod:`pavement_mcmc.posterior.input_noise`), the noise of the bottom boundary
and initial temperatures is integrated out: the residuals are whitened by the resulting
covariance instead of divided by sigma.

Heat-flux plates (a model with ``plates``) are a second kind of observation: independent
Gaussian errors with a sd per reading, ``flux_sd`` (an absolute floor and a share of the
reading; the plate's systematic calibration error is the model's ``plate_<label>`` factor).
Their whitened residuals follow the temperatures' in :meth:`LogPosterior.whitened`, the one
misfit every other module uses.
"""

from __future__ import annotations

import numpy as np

from ..parameters import ParameterSpace
from ..physics.model import Model

_LOG_2PI = np.log(2.0 * np.pi)


class LogPosterior:
    """Log-posterior of a model given its measurements.

    Parameters
    ----------
    model : the forward model (its ``meas`` are the data).
    space : the parameter space (free parameters, bounds, priors, joint priors).
    """

    def __init__(self, model: Model, space: ParameterSpace, flux_sd: np.ndarray | None = None):
        self.model = model
        self.space = space
        self.meas = model.meas
        self.obs = model.meas.T_obs[1:]  # (n_obs-1, n_sensors)
        self.sigma = float(model.meas.sigma)
        self.n_data = self.obs.size
        self.input_noise = None  # an InputNoise, or None: boundary and initial data exact
        self._grad_cols = None  # (model gradient names, source and free columns), cached
        self.flux_obs = self.flux_sd = None
        if model.plates:
            self.flux_obs = model.meas.G_obs[1:]  # (n_obs-1, n_plates)
            sd = default_flux_sd(self.flux_obs) if flux_sd is None else np.asarray(flux_sd, float)
            self.flux_sd = np.broadcast_to(sd, self.flux_obs.shape).copy()
            if not np.all(self.flux_sd > 0):
                raise ValueError("flux_sd must be > 0 for every plate reading")

    @property
    def names(self) -> list[str]:
        return self.space.free

    @property
    def blob_names(self) -> list[str]:
        """RMSE per sensor (degC), then per plate (W m-2)."""
        plates = self.meas.plate_labels if self.flux_obs is not None else []
        return [f"rmse_{lab}" for lab in [*self.meas.sensor_labels, *plates]]

    @property
    def ndim(self) -> int:
        return len(self.space.free)

    def predict(self, theta: np.ndarray) -> np.ndarray:
        """Predicted sensor temperatures, (n_sets, n_obs, n_sensors), degC."""
        return self.model.predict(self.space.expand(theta))

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """Predicted minus observed temperatures, (n_sets, n_obs - 1, n_sensors), degC."""
        return self.predict(theta)[:, 1:, :] - self.obs

    def data_residuals(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Temperature residuals (as :meth:`residuals`) and plate residuals (n_sets, n_obs - 1,
        n_plates) in W m-2 (None without plates), from one solve."""
        p = self.space.expand(theta)
        model = self.model
        if self.flux_obs is None:
            return model.predict(p)[:, 1:, :] - self.obs, None
        coeffs = model.coefficients(p)
        from ..solver import solve

        T_nodes = solve(model.grid, model.forcing, coeffs, scheme=model.scheme)
        rT = model.observe(T_nodes, p)[:, 1:, :] - self.obs
        return rT, model.observe_flux(T_nodes, coeffs, p)[:, 1:, :] - self.flux_obs

    def whiten(self, rT: np.ndarray, rG: np.ndarray | None = None) -> np.ndarray:
        """All whitened residuals (..., n_data + n_flux): the temperatures'
        (:meth:`standardized_residuals`), then the plates' divided by their sd."""
        z = self.standardized_residuals(rT)
        if rG is None:
            return z
        zG = (rG / self.flux_sd).reshape(*rG.shape[:-2], -1)
        return np.concatenate([z, zG], axis=-1)

    def whitened(self, theta: np.ndarray) -> np.ndarray:
        """The whitened residuals of ``theta`` (n_sets, n_data + n_flux): the one misfit."""
        return self.whiten(*self.data_residuals(theta))

    def loglik_blobs(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihood (n_sets,) and blobs (RMSE per sensor, then per plate) of ``theta``."""
        rT, rG = self.data_residuals(theta)
        ll = self._loglik_whitened(self.whiten(rT, rG))
        rmse = np.sqrt(np.mean(rT * rT, axis=1))
        if rG is not None:
            rmse = np.concatenate([rmse, np.sqrt(np.mean(rG * rG, axis=1))], axis=1)
        return ll, rmse

    def standardized_residuals(self, r: np.ndarray) -> np.ndarray:
        """Whitened residuals (..., n_data) of residual arrays (..., n_obs-1, n_sensors):
        ``r / sigma``, or ``Sigma^(-1/2) r`` with noisy inputs."""
        flat = r.reshape(*r.shape[:-2], -1)
        if self.input_noise is None:
            return flat / self.sigma
        return self.input_noise.whiten(flat)

    def log_likelihood_from_residuals(self, r: np.ndarray) -> np.ndarray:
        """Gaussian log-likelihood of residual arrays (..., n_obs-1, n_sensors)."""
        return self._loglik_whitened(self.standardized_residuals(r))

    def _loglik_whitened(self, z: np.ndarray) -> np.ndarray:
        logdet = (self.n_data * np.log(self.sigma**2) if self.input_noise is None
                  else self.input_noise.logdet)
        n = self.n_data
        if self.flux_sd is not None and z.shape[-1] > self.n_data:
            logdet = logdet + 2.0 * float(np.sum(np.log(self.flux_sd)))
            n += self.flux_sd.size
        return -0.5 * (np.sum(z * z, axis=-1) + logdet + n * _LOG_2PI)

    def _weighted(self, z: np.ndarray) -> np.ndarray:
        """``W^T z`` for whitened residuals ``z`` (..., n_data) (``W = Sigma^(-1/2)``, symmetric)."""
        return z / self.sigma if self.input_noise is None else self.input_noise.whiten(z)

    @property
    def has_gradient(self) -> bool:
        """Whether :meth:`loglik_and_grad` uses the solver's adjoint (else finite differences)."""
        return bool(getattr(self.model, "has_gradient", False))

    def loglik_and_grad(self, theta: np.ndarray, method: str = "auto", fd_step: float = 1e-6):
        """Log-likelihood (n,), its gradient with respect to ``theta`` (n, n_free) and the blobs
        (n, n_sensors), for rows inside the bounds.

        ``method``: ``"adjoint"`` (the solver's discrete adjoint, about 1.5-2 log-posterior
        evaluations; needs :attr:`has_gradient`), ``"fd"`` (central differences, one-sided at a
        bound, ``2 n_free + 1`` solves per row, relative step ``fd_step``), or ``"auto"`` (the
        adjoint when available).
        """
        theta = np.atleast_2d(np.asarray(theta, float))
        if method not in ("auto", "adjoint", "fd"):
            raise ValueError(f"method must be 'auto', 'adjoint' or 'fd', got {method!r}")
        if method == "fd" or (method == "auto" and not self.has_gradient):
            return self._loglik_and_grad_fd(theta, fd_step)
        p = self.space.expand(theta)
        model = self.model
        keep = {}

        def cotangent(T_nodes, coeffs):
            pred = model.observe(T_nodes, p)
            r = pred[:, 1:, :] - self.obs
            z = self.standardized_residuals(r)
            rG = None
            if self.flux_obs is not None:
                G = model.observe_flux(T_nodes, coeffs, p)
                rG = G[:, 1:, :] - self.flux_obs
                zG = (rG / self.flux_sd).reshape(rG.shape[0], -1)
                ll = self._loglik_whitened(np.concatenate([z, zG], axis=1))
            else:
                ll = self._loglik_whitened(z)
            ok = np.isfinite(ll)
            keep["ll"] = np.where(ok, ll, -np.inf)
            keep["rmse"] = np.sqrt(np.mean(r * r, axis=1))
            gp = np.zeros_like(pred)
            gp[:, 1:, :] = -self._weighted(np.where(ok[:, None], z, 0.0)).reshape(r.shape)
            gT, direct = model.observe_vjp(gp, T_nodes, p)  # rows with a non-finite fit: 0
            if rG is not None:
                keep["rmse"] = np.concatenate([keep["rmse"], np.sqrt(np.mean(rG * rG, axis=1))], axis=1)
                gG = np.zeros_like(G)
                gG[:, 1:, :] = -np.where(ok[:, None, None], rG, 0.0) / self.flux_sd**2
                gT, df = model.observe_flux_vjp(gG, T_nodes, coeffs, p, gT)  # adds into gT
                direct.update(df)
            return gT, direct

        _, names, G = model.solve_vjp(p, cotangent)
        if self._grad_cols is None or self._grad_cols[0] != names:
            col = {n: i for i, n in enumerate(self.space.free)}
            pairs = [(j, col[n]) for j, n in enumerate(names) if n in col]
            self._grad_cols = (names, np.array([a for a, _ in pairs]), np.array([b for _, b in pairs]))
        _, src, dst = self._grad_cols
        grad = np.zeros(theta.shape)  # parameters the likelihood does not see (gamma): 0
        grad[:, dst] = G[:, src]
        return keep["ll"], grad, keep["rmse"]

    def _loglik_and_grad_fd(self, theta: np.ndarray, fd_step: float):
        """Central differences, one-sided where a bound is closer than the step (h = 0)."""
        n, d = theta.shape
        lo, hi = self.space.bounds()
        step = fd_step * np.maximum(np.abs(theta), 1e-3)
        up, down = np.minimum(theta + step, hi), np.maximum(theta - step, lo)
        X = np.repeat(theta[:, None, :], 2 * d + 1, axis=1)
        X[:, 1 + np.arange(d), np.arange(d)] = up
        X[:, 1 + d + np.arange(d), np.arange(d)] = down
        with np.errstate(all="ignore"):
            ll, rmse = self.loglik_blobs(X.reshape(-1, d))
            ll = ll.reshape(n, 2 * d + 1)
            rmse = rmse.reshape(n, 2 * d + 1, -1)[:, 0]
            grad = (ll[:, 1:d + 1] - ll[:, d + 1:]) / (up - down)
        return ll[:, 0], np.where(up > down, grad, 0.0), rmse

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
        blobs = np.full((n_sets, len(self.blob_names)), np.inf)
        if ok.any():
            with np.errstate(all="ignore"):
                ll, rmse = self.loglik_blobs(theta[ok])
            good = np.isfinite(ll)
            vals = np.where(good, lp[ok] + ll, -np.inf)
            out[ok] = vals
            blobs[ok] = np.where(good[:, None], rmse, np.inf)
        return out, blobs

    def log_prob(self, theta: np.ndarray) -> np.ndarray:
        """Log-posterior only, (n_sets,)."""
        return self(theta)[0]


def default_flux_sd(G_obs: np.ndarray, abs_sd: float = 2.0, rel_sd: float = 0.1) -> np.ndarray:
    """Sd of each plate reading, W m-2: ``sqrt(abs_sd^2 + (rel_sd G)^2)`` (a floor and a share
    of the reading; the calibration error is the separate factor parameter)."""
    return np.sqrt(abs_sd**2 + (rel_sd * np.asarray(G_obs, float)) ** 2)
