"""The log-posterior: priors + a Gaussian likelihood over observation streams, vectorised.

``LogPosterior(theta)`` takes the free parameters of many sets at once, ``(n_sets, n_free)``,
and returns ``(log_post (n_sets,), blobs (n_sets, n_blobs))`` where the blobs are the RMSE of
each column of each stream (degC per sensor, W m-2 per plate, ...). Sets outside the bounds or
prior support get ``-inf`` (and ``inf`` blobs) without being solved, without warnings and
without NaN. There is no Python loop over sets.

The likelihood is a list of observation streams (:mod:`.observations`): the buried sensors'
temperatures first (:class:`~.observations.Temperatures`), then the heat-flux plates
(:class:`~.observations.Plates`) where the model observes them, then any other stream (the
infrared surface temperature, :class:`~.surface_ir.SurfaceIR`). Each stream predicts from the
one solve, whitens its own residuals and gives its log-determinant and its adjoint; their
whitened residuals, concatenated in that order (:meth:`LogPosterior.whitened`), are the one
misfit every other module uses. The first observation row is the initial condition (the
solver starts from the sensors' values interpolated at t = 0), so it carries no information
and is left out.

With ``input_noise`` set (:mod:`pavement_mcmc.posterior.input_noise`), the noise of the bottom
boundary and initial temperatures is integrated out: the temperatures' residuals are whitened
by the resulting covariance instead of divided by sigma.
"""

from __future__ import annotations

import numpy as np

from ..parameters import ParameterSpace
from ..physics.model import Model
from ..solver import solve
from .observations import Observation, Plates, Temperatures, default_flux_sd, log_likelihood
from .plain_gradient import PlainGradient

__all__ = ["LogPosterior", "default_flux_sd", "default_streams"]

_LOG_2PI = np.log(2.0 * np.pi)


def default_streams(model: Model, flux_sd: np.ndarray | None = None) -> list[Observation]:
    """The model's own streams: its sensors' temperatures, and its plates if it observes them."""
    out: list[Observation] = [Temperatures(model.meas)]
    if model.plates:
        out.append(Plates(model.meas, flux_sd))
    return out


class LogPosterior:
    """Log-posterior of a model given its measurements.

    Parameters
    ----------
    model : the forward model (its ``meas`` are the data).
    space : the parameter space (free parameters, bounds, priors, joint priors).
    flux_sd : sd of each plate reading (default :func:`default_flux_sd`), when ``streams`` is
        not given.
    streams : the observation streams (default :func:`default_streams`); the first must be the
        model's :class:`~.observations.Temperatures`.
    """

    def __init__(self, model: Model, space: ParameterSpace, flux_sd: np.ndarray | None = None,
                 streams: list[Observation] | None = None):
        self.model = model
        self.space = space
        self.meas = model.meas
        self.streams = default_streams(model, flux_sd) if streams is None else list(streams)
        if not isinstance(self.streams[0], Temperatures):
            raise ValueError("the first observation stream must be the sensors' temperatures")
        self._grad_cols = None  # (model gradient names, source and free columns), cached
        self._plain = None  # a PlainGradient when the model is plain, else False (decided once)

    # -- the temperature stream (the paper's likelihood) and the plates, by their old names ------
    @property
    def temperatures(self) -> Temperatures:
        return self.streams[0]

    @property
    def input_noise(self):
        """An :class:`~.input_noise.InputNoise` whitening the temperatures, or None (exact
        boundary and initial data)."""
        return self.temperatures.input_noise

    @input_noise.setter
    def input_noise(self, value) -> None:
        self.temperatures.input_noise = value

    @property
    def obs(self) -> np.ndarray:
        """Observed temperatures after the initial row (n_obs - 1, n_sensors)."""
        return self.temperatures.data

    @property
    def sigma(self) -> float:
        return self.temperatures.sigma

    @property
    def n_data(self) -> int:
        return self.temperatures.size

    def stream(self, name: str) -> Observation | None:
        """The stream called ``name`` (``"temperatures"``, ``"plates"``, ...), or None."""
        return next((s for s in self.streams if s.name == name), None)

    @property
    def flux_obs(self) -> np.ndarray | None:
        s = self.stream("plates")
        return None if s is None else s.data

    @property
    def flux_sd(self) -> np.ndarray | None:
        s = self.stream("plates")
        return None if s is None else s.sd

    @property
    def n_whitened(self) -> int:
        """Number of whitened residuals of :meth:`whitened` (every stream's data)."""
        return sum(s.size for s in self.streams)

    @property
    def names(self) -> list[str]:
        return self.space.free

    @property
    def blob_names(self) -> list[str]:
        """RMSE per sensor (degC), then per column of the other streams (plates: W m-2)."""
        return [f"rmse_{lab}" for s in self.streams for lab in s.labels]

    @property
    def ndim(self) -> int:
        return len(self.space.free)

    # -- residuals -----------------------------------------------------------------------------
    def predict(self, theta: np.ndarray) -> np.ndarray:
        """Predicted sensor temperatures, (n_sets, n_obs, n_sensors), degC."""
        return self.model.predict(self.space.expand(theta))

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """Predicted minus observed temperatures, (n_sets, n_obs - 1, n_sensors), degC."""
        return self.predict(theta)[:, 1:, :] - self.obs

    def data_residuals(self, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """Every stream's residuals (n_sets, n_obs - 1, n_cols), in stream order (the
        temperatures', degC, first; then the plates', W m-2, ...), from one solve."""
        p = self.space.expand(theta)
        model = self.model
        if len(self.streams) == 1:
            return (model.predict(p)[:, 1:, :] - self.obs,)
        coeffs = model.coefficients(p)
        T_nodes = solve(model.grid, model.forcing, coeffs, scheme=model.scheme)
        return tuple(s.residuals(model, T_nodes, coeffs, p) for s in self.streams)

    def whiten(self, *residuals: np.ndarray | None) -> np.ndarray:
        """All whitened residuals (..., n_whitened) of the streams' residual arrays (as
        :meth:`data_residuals`; a None is skipped), concatenated in stream order."""
        z = [s.whiten(r) for s, r in zip(self.streams, residuals, strict=False) if r is not None]
        return z[0] if len(z) == 1 else np.concatenate(z, axis=-1)

    def whitened(self, theta: np.ndarray) -> np.ndarray:
        """The whitened residuals of ``theta`` (n_sets, n_whitened): the one misfit."""
        return self.whiten(*self.data_residuals(theta))

    def loglik_blobs(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihood (n_sets,) and blobs (RMSE per column of each stream) of ``theta``."""
        temps, model = self.streams[0], self.model
        if len(self.streams) == 1 and temps.compiled_applies(model):  # the same numbers, compiled
            out = temps.compiled_loglik(model, model.solve(self.space.expand(theta)))
            if out is not None:
                return out
        rs = self.data_residuals(theta)
        ll = log_likelihood(self.streams, self.whiten(*rs))
        rmse = [np.sqrt(np.mean(r * r, axis=1)) for r in rs]
        return ll, rmse[0] if len(rmse) == 1 else np.concatenate(rmse, axis=1)

    def standardized_residuals(self, r: np.ndarray) -> np.ndarray:
        """Whitened temperature residuals (..., n_data) of residual arrays (..., n_obs-1,
        n_sensors): ``r / sigma``, or ``Sigma^(-1/2) r`` with noisy inputs."""
        return self.temperatures.whiten(r)

    def marginal_sd(self) -> np.ndarray:
        """Sd of each temperature datum alone (n_obs - 1, n_sensors), degC: sigma, or with noisy
        inputs each datum's marginal sd (the inputs' share included)."""
        return self.temperatures.marginal_sd()

    def log_likelihood_from_residuals(self, r: np.ndarray) -> np.ndarray:
        """Gaussian log-likelihood of temperature residual arrays (..., n_obs-1, n_sensors)."""
        return log_likelihood(self.streams[:1], self.standardized_residuals(r))

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
        if self._plain is None or (self._plain and (self._plain.model is not model
                                                    or self._plain.temps is not self.streams[0])):
            self._plain = PlainGradient(model, self.streams[0]) if PlainGradient.applies(model) else False
        plain = self._plain(p) if self._plain and len(self.streams) == 1 else None
        if plain is not None:  # the same numbers without the generic glue
            ll, G, rmse = plain
            return ll, self._free_gradient(theta, self._plain.names, G), rmse
        keep = {}
        temps = self.streams[0]
        compiled = temps.compiled_applies(model)
        alone = len(self.streams) == 1

        def cotangent(T_nodes, coeffs):
            terms = temps.compiled_terms(model, T_nodes, alone) if compiled else None
            if terms is not None and alone:  # the plain temperatures: two compiled calls
                keep["ll"], keep["rmse"], gT = terms
                return gT, {}
            # the temperatures' whitened residuals and RMSE from the compiled path when it
            # applies (the same numbers as predict / whiten), the other streams' in NumPy
            rest = self.streams[1:] if terms is not None else self.streams
            preds = [st.predict(model, T_nodes, coeffs, p) for st in rest]
            rs = [pr[:, 1:, :] - st.data for st, pr in zip(rest, preds, strict=True)]
            zs = [st.whiten(r) for st, r in zip(rest, rs, strict=True)]
            rmse = [np.sqrt(np.mean(r * r, axis=1)) for r in rs]
            if terms is not None:
                zs.insert(0, terms[0])
                rmse.insert(0, terms[1])
            ll = log_likelihood(self.streams, zs[0] if len(zs) == 1 else np.concatenate(zs, axis=1))
            ok = np.isfinite(ll)
            keep["ll"] = np.where(ok, ll, -np.inf)
            keep["rmse"] = rmse[0] if len(rmse) == 1 else np.concatenate(rmse, axis=1)
            gT, direct = None, {}
            if terms is not None:
                gT = temps.compiled_cotangent(model, T_nodes, terms[0], ok)
                zs = zs[1:]
            for st, pr, r, z in zip(rest, preds, rs, zs, strict=True):
                gT, d = st.vjp(model, pr, r, z, ok, T_nodes, coeffs, p, gT)
                for k, v in d.items():
                    direct[k] = direct[k] + v if k in direct else v
            return gT, direct

        _, names, G = model.solve_vjp(p, cotangent)
        return keep["ll"], self._free_gradient(theta, names, G), keep["rmse"]

    def _free_gradient(self, theta: np.ndarray, names, G: np.ndarray) -> np.ndarray:
        """The model's gradient ``G`` (columns ``names``) in the free columns of ``theta``."""
        names = list(names)
        if self._grad_cols is None or self._grad_cols[0] != names:
            col = {n: i for i, n in enumerate(self.space.free)}
            pairs = [(j, col[n]) for j, n in enumerate(names) if n in col]
            self._grad_cols = (names, np.array([a for a, _ in pairs]), np.array([b for _, b in pairs]))
        _, src, dst = self._grad_cols
        grad = np.zeros(theta.shape)  # parameters the likelihood does not see (gamma): 0
        grad[:, dst] = G[:, src]
        return grad

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
        """Log-likelihood of each temperature datum, (n_sets, n_obs - 1, n_sensors) (for ArviZ /
        LOO). With noisy inputs, each datum's marginal density (its sd includes the inputs' share)."""
        r = self.residuals(theta)
        sd = self.sigma if self.input_noise is None else self.marginal_sd()
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

