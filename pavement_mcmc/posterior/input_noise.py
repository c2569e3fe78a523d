r"""Noisy inputs (boundary, initial, air temperatures, net radiation) integrated out of the likelihood.

The solver takes the deepest sensor's series as the Dirichlet bottom boundary and every sensor's
first reading as the initial profile. Both are measurements with the same kind of noise as the
observations, but the paper's likelihood treats them as exact. Their errors then reach the
predictions (the 4 cm sensor follows the 5 cm boundary almost one to one), the residuals are
larger and correlated, and the posterior is too narrow: the simulation-based calibration of
Case A with noisy inputs gives U-shaped ranks for kappa.

For fixed parameters the predictions are linear in these inputs (exactly for the conduction
model, to first order with nonlinear extensions):
:math:`T_\mathrm{pred}(u + \varepsilon) = T_\mathrm{pred}(u) + U\varepsilon`, with
:math:`U = \partial T_\mathrm{pred} / \partial u` (``n_data x n_inputs``; inputs: the bottom
value at every observation time and the initial reading of every observed sensor; optionally
also the air temperature and the net radiation at every observation time, whose errors matter
at night, when h multiplies a small T_air - T_s). With
:math:`\varepsilon \sim N(0, \sigma_\mathrm{in}^2 I)` per kind integrated out, the data are
Gaussian with covariance

.. math:: \Sigma = \sigma^2 I + \sum_k \sigma_k^2\, U_k U_k^T .

``U`` is computed once, by finite differences at a reference point (the MAP with exact inputs),
and kept fixed: a plug-in approximation that keeps the likelihood one batched solve plus two
thin matrix products per set. With :math:`V = \sigma_\mathrm{in} U / \sigma = Q\,\mathrm{diag}(s)
P^T` (thin SVD), :math:`\Sigma^{-1/2} = \bigl(I + Q\,\mathrm{diag}((1+s^2)^{-1/2} - 1)\,Q^T\bigr)
/ \sigma` whitens the residuals and :math:`\log\det\Sigma = n \log\sigma^2 + \sum\log(1+s^2)`.

Errors are taken as independent between readings (a calibration bias is not white noise: it
is better modelled as a parameter, e.g. the ``radiation_factor`` or ``sensor_bias`` extension).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..solver import Forcing, solve

__all__ = ["INPUT_KINDS", "InputNoise", "input_jacobian"]


@dataclass(frozen=True)
class InputNoise:
    """The whitening of residuals under noisy inputs (see the module docstring).

    Attributes
    ----------
    sigma : observation noise sd, degC.
    sigma_in : noise sd per input kind (``INPUT_KINDS``), degC or W m-2.
    Q : (n_data, r) left singular vectors of ``sigma_in U / sigma``.
    d : (r,) ``(1 + s^2)^(-1/2) - 1``.
    logdet : ``log det Sigma``.
    marginal_sd : (n_data,) sd of each datum, ``sqrt(sigma^2 + sigma_in^2 (U U^T)_ii)``.
    F : (n_data, n_inputs) ``sigma_in U``, so that ``Sigma = sigma^2 I + F F^T``.
    """

    sigma: float
    sigma_in: dict
    Q: np.ndarray
    d: np.ndarray
    logdet: float
    marginal_sd: np.ndarray
    F: np.ndarray | None = None

    @classmethod
    def from_jacobian(cls, U: dict[str, np.ndarray], sigma: float,
                      sigmas: dict[str, float]) -> InputNoise:
        """Independent input errors, sd ``sigmas[kind]`` (a number, or one per column) for the
        columns ``U[kind]``: ``Sigma = sigma^2 I + sum_k sigmas[k]^2 U_k U_k^T``."""
        if not sigma > 0 or any(not np.all(np.asarray(v) >= 0) for v in sigmas.values()):
            raise ValueError(f"need sigma > 0 and input sds >= 0; got {sigma}, {sigmas}")
        F = np.concatenate([np.asarray(sigmas[k], float) * np.asarray(U[k], float) for k in sigmas],
                           axis=1)  # Sigma = sigma^2 I + F F^T
        return cls._from_factor(F, float(sigma), dict(sigmas))

    @classmethod
    def _from_factor(cls, F: np.ndarray, sigma: float, sigmas: dict) -> InputNoise:
        Q, s, _ = np.linalg.svd(F / sigma, full_matrices=False)
        keep = s**2 > 1e-4  # smaller terms change no whitened residual by more than 5e-5
        Q, s = Q[:, keep], s[keep]
        n = F.shape[0]
        logdet = n * np.log(sigma**2) + float(np.sum(np.log1p(s**2)))
        sd = np.sqrt(sigma**2 + np.sum(F * F, axis=1))
        return cls(sigma, sigmas, Q, 1.0 / np.sqrt(1.0 + s**2) - 1.0, logdet, sd, F)

    def subset(self, rows: np.ndarray) -> InputNoise:
        """The whitening of the data ``rows`` alone (a boolean mask or indices): the covariance
        of a subset of Gaussian data is the sub-matrix of ``Sigma`` (hold-out checks)."""
        return self._from_factor(self.F[rows], self.sigma, self.sigma_in)

    def whiten(self, r: np.ndarray) -> np.ndarray:
        """``Sigma^(-1/2) r`` for residual rows ``r`` (..., n_data)."""
        return (r + ((r @ self.Q) * self.d) @ self.Q.T) / self.sigma


#: the inputs whose noise can be integrated out (columns of their Jacobian blocks)
INPUT_KINDS = ("bottom", "initial", "top", "T_air", "q_net")


def input_jacobian(model, p: dict[str, np.ndarray], kinds=None,
                   delta: float = 0.1) -> dict[str, np.ndarray]:
    """``d T_pred / d inputs`` at ONE parameter set ``p`` (a dict of length-1 arrays), per kind.

    Rows: the observations after the initial row, flattened (time-major, sensors fastest), as in
    :meth:`~pavement_mcmc.posterior.LogPosterior.residuals`. Columns: ``"bottom"`` the bottom
    temperature at every observation time; ``"initial"`` the initial reading of every observed
    sensor; ``"top"`` a measured top boundary at every observation time; ``"T_air"`` the air
    temperature and ``"q_net"`` the net radiation at every observation time (``q_net`` perturbed
    after the extensions' surface hooks). One-sided differences of ``delta`` (degC or W m-2;
    exact for the linear conduction model). ``kinds``: default every kind the model has
    (``"top"`` only with a measured top).
    """
    if kinds is None:
        kinds = tuple(k for k in INPUT_KINDS if k != "top" or model.forcing.T_top is not None)
    unknown = set(kinds) - set(INPUT_KINDS)
    if unknown:
        raise ValueError(f"unknown input kinds {sorted(unknown)}; valid: {list(INPUT_KINDS)}")
    meas, grid = model.meas, model.grid
    coeffs = model.coefficients(p)
    base = model.forcing

    def predict(forcing: Forcing, c=coeffs) -> np.ndarray:
        T = solve(grid, forcing, c, scheme=model.scheme)
        return model.observe(T, p)[0, 1:, :].ravel()

    top = base.T_top is not None
    if "top" in kinds and not top:
        raise ValueError("input kind 'top' needs a measured top boundary")
    # the initial profile interpolates [top,] the observed sensors and the bottom at t = 0
    depths = np.concatenate([[0.0] if top else [], meas.depths, [meas.bottom_depth]])
    n_obs, n_s = meas.n_obs, meas.n_sensors

    def initial(k: int) -> np.ndarray:  # delta x the initial profile's response to reading k
        return delta * np.interp(np.maximum(grid.soil_x, 0.0), depths, np.eye(depths.size)[k])

    ref = predict(base)
    out = {}
    for kind in kinds:
        cols = []
        if kind in ("bottom", "top"):  # at t = 0 also an end of the initial profile
            series, end = ("T_bottom", depths.size - 1) if kind == "bottom" else ("T_top", 0)
            for j in range(n_obs):
                v = getattr(base, series).copy()
                v[j] += delta
                T0 = base.T0 + (initial(end) if j == 0 else 0.0)
                cols.append(predict(replace(base, **{series: v, "T0": T0})))
        elif kind == "initial":
            for k in range(n_s):
                cols.append(predict(replace(base, T0=base.T0 + initial(k + int(top)))))
        elif kind == "T_air":
            for j in range(n_obs):
                Ta = base.T_air.copy()
                Ta[j] += delta
                cols.append(predict(replace(base, T_air=Ta)))
        else:
            for j in range(n_obs):
                q = coeffs.q.copy()
                q[:, j] += delta
                cols.append(predict(base, replace(coeffs, q=q)))
        out[kind] = (np.stack(cols, axis=1) - ref[:, None]) / delta
    return out
