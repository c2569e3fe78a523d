r"""Quick MAP refits for the criticism, on top of :func:`pavement_mcmc.posterior.map.find_map`.

A refit returns, besides the MAP point, the two parts of the MAP objective
:math:`\Phi = \chi^2 + P` (``chi2``: the sum of squared whitened data residuals of the posterior,
:meth:`~pavement_mcmc.posterior.LogPosterior.standardized_residuals`, first observation row left
out as in the likelihood; ``P``: the squared prior residuals of the
Gaussian priors and of the smoothness prior, i.e. :math:`-2\log\pi` up to a constant) and the
**effective number of data-determined parameters**

.. math:: p_\mathrm{eff} = \mathrm{tr}\left[(J^T J)^{-1} J_d^T J_d\right]

(:math:`J` the Jacobian of all whitened residuals, :math:`J_d` its data rows): a parameter the
data pin counts 1, one held only by its prior counts 0 — e.g. ``rad_factor``, which the data
cannot separate from a common scale of kappa, C and h, counts only what the priors on kappa and
C let the data decide. The parameter counts of model comparisons use :math:`p_\mathrm{eff}`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..posterior import find_map


@dataclass(frozen=True)
class Fit:
    """A MAP refit of one model.

    Attributes
    ----------
    problem : the :class:`~pavement_mcmc.posterior.Problem` that was fitted.
    names : free-parameter names, in the order of ``theta``.
    theta : (n_free,) MAP estimate.
    chi2 : sum of squared standardised data residuals.
    prior_penalty : sum of squared prior residuals.
    p_eff : effective number of data-determined parameters.
    residuals : (n_obs - 1, n_sensors) predicted minus observed, degC.
    whitened : (n_obs - 1, n_sensors) the posterior's whitened temperature residuals
        (:meth:`~pavement_mcmc.posterior.LogPosterior.standardized_residuals`: ``residuals /
        sigma``, or with noisy inputs ``Sigma^(-1/2) residuals``).
    n_evals : parameter sets solved by the fit.
    """

    problem: object
    names: list[str]
    theta: np.ndarray
    chi2: float
    prior_penalty: float
    p_eff: float
    residuals: np.ndarray
    whitened: np.ndarray
    n_evals: int

    @property
    def objective(self) -> float:
        return self.chi2 + self.prior_penalty

    @property
    def rmse(self) -> float:
        return float(np.sqrt(np.mean(self.residuals**2)))

    @property
    def rmse_sigma(self) -> float:
        """The temperatures' misfit in noise units, ``sqrt(mean(whitened^2))`` (the RMSE over
        sigma when the inputs are exact)."""
        return float(np.sqrt(np.mean(self.whitened**2)))

    def values(self) -> dict[str, float]:
        """Every parameter of the problem (free at the estimate, fixed at its value)."""
        p = self.problem.space.expand(self.theta[None, :])
        return {k: float(v[0]) for k, v in p.items()}


def prior_penalty(space, theta: np.ndarray) -> float:
    """Sum of squared prior residuals of ``theta`` (:class:`~pavement_mcmc.parameters.PriorResiduals`:
    Gaussian priors and the smoothness prior)."""
    return float(space.prior_residuals().penalty(np.asarray(theta, float)[None, :])[0])


#: relative tolerance of the refits' refinement to the mode in log coordinates
#: (:func:`~pavement_mcmc.posterior.map_steps.refine_log`): it stops when a step gains less than
#: this fraction of the objective (about 1e-3 of ~300, where the samplers' starts ask 1e-10):
#: the criticism's scores are differences of objectives compared to within units, and the
#: refinement's last steps gain less and less (measured on a campaign twin: 60 steps, the
#: last 30 gaining 1e-3 to 2e-8 each); a campaign twin's diagnosis: 9.3 -> 7.5 s CPU
REFINE_TOL = 3e-6


def refit(problem, start: dict[str, float] | None = None, *, max_nfev: int = 100) -> Fit:
    """MAP refit of ``problem`` from ``start`` (a dict of values by name).

    Parameters
    ----------
    problem : a :class:`~pavement_mcmc.posterior.Problem`.
    start : starting values; parameters not named start at their ``value``.
    max_nfev : least-squares iterations.

    Returns
    -------
    Fit
    """
    post = problem.posterior
    lap = find_map(post, problem.space.start_vector(start), max_nfev=max_nfev,
                   refine_tol=REFINE_TOL)
    theta = np.asarray(lap.theta, float)
    rs = post.data_residuals(theta[None, :])
    chi2 = float(np.sum(post.whiten(*rs) ** 2))
    return Fit(
        problem=problem,
        names=list(lap.names),
        theta=theta,
        chi2=chi2,
        prior_penalty=prior_penalty(problem.space, theta),
        p_eff=_p_eff(post, lap),
        residuals=rs[0][0],
        whitened=post.standardized_residuals(rs[0])[0].reshape(rs[0].shape[1:]),
        n_evals=int(lap.n_evals),
    )


def _p_eff(post, lap) -> float:
    """tr[(J^T J)^-1 J_d^T J_d] in the scaled coordinates of the fit."""
    idx, scale = lap.idx, lap.scale
    k = idx.size
    if k == 0:
        return 0.0
    z = lap.theta[idx] / scale
    step = 1e-5 * np.maximum(np.abs(z), 1.0)
    lo, hi = post.space.bounds()
    Z = np.repeat(lap.theta[None, :], 2 * k, axis=0)
    up = np.minimum(z + step, hi[idx] / scale)
    dn = np.maximum(z - step, lo[idx] / scale)
    Z[np.arange(k), idx] = up * scale
    Z[k + np.arange(k), idx] = dn * scale
    with np.errstate(all="ignore"):
        R = post.whitened(Z)
    Jd = ((R[:k] - R[k:]) / (up - dn)[:, None]).T
    Jd = np.where(np.isfinite(Jd), Jd, 0.0)
    Hd = Jd.T @ Jd
    prec = post.space.prior_residuals().precision(len(post.space.free))[idx] * scale**2
    K = Hd + np.diag(prec) + lap.gamma_hat * lap.B
    try:
        return float(np.trace(np.linalg.solve(K + 1e-12 * np.trace(K) / k * np.eye(k), Hd)))
    except np.linalg.LinAlgError:
        return float(k)
