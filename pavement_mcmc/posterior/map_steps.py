"""The MAP's inner steps (:func:`~pavement_mcmc.posterior.map.find_map`): the EM update of a
free smoothness precision gamma and the refinement to the mode in log coordinates."""

from __future__ import annotations

import numpy as np
from scipy import optimize

__all__ = ["expected_roughness", "gamma_update", "gamma_variance", "refine_log"]


def gamma_update(space, gname, N, S_eff) -> float:
    """argmax over gamma of (N-1)/2 log g - g S/2 + log prior(g) (optimised in log g)."""
    prior = space[gname].prior

    def negf(u):
        g = np.exp(u)
        lp = float(np.asarray(prior.logpdf(np.array([g])))[0])
        return -(0.5 * (N - 1) * u - 0.5 * g * S_eff + lp)

    res = optimize.minimize_scalar(negf, bounds=(np.log(1e-8), np.log(1e8)), method="bounded",
                                   options={"xatol": 1e-8})
    return float(np.exp(res.x))


def gamma_variance(space, gname, N, S, g) -> float:
    """Variance of gamma from the curvature of the same objective at ``g`` (sum of squares
    ``S``)."""
    prior = space[gname].prior
    eps = 1e-4 * g

    def f(x):
        return 0.5 * (N - 1) * np.log(x) - 0.5 * x * S + float(np.asarray(prior.logpdf(np.array([x])))[0])

    d2 = (f(g + eps) - 2 * f(g) + f(g - eps)) / eps**2
    return float(1.0 / max(-d2, 1e-12))


def expected_roughness(res_fn, idx, gmrf_cols, z, gamma) -> float:
    """``E|Dh|^2 = |D h|^2 + tr(D Sigma_hh D^T)`` under the Laplace approximation at ``z``."""
    J = res_fn.jac(z, gamma)
    Kz = J.T @ J
    cov_z = np.linalg.pinv(Kz)
    hz = gmrf_cols
    sh = res_fn.dtheta_dz(z)[hz]
    h = res_fn.theta(z)[0, idx[hz]]
    Sig_h = cov_z[np.ix_(hz, hz)] * np.outer(sh, sh)
    Dh = np.diff(h)
    tr = np.trace(Sig_h[1:, 1:] - Sig_h[1:, :-1] - Sig_h[:-1, 1:] + Sig_h[:-1, :-1])
    return float(Dh @ Dh + tr)


def refine_log(res_fn, z, gamma, lo_z, hi_z, max_iter: int = 60, tol: float = 1e-10):
    """Damped Gauss–Newton on ``F(z) = |r|^2/2 - sum_{log} z`` (the mode in log coordinates,
    where the Jacobian of ``theta = exp(z)`` adds ``-z`` per log-transformed parameter); stops
    when a step lowers ``F`` by less than ``tol`` times ``max(1, |F|)``."""
    e = res_fn.logc.astype(float)

    def F(v):
        r = res_fn(v[None, :], gamma)[0]
        return 0.5 * r @ r - e @ v, r

    f, r = F(z)
    lam = 1e-3
    for _ in range(max_iter):
        J = res_fn.jac(z, gamma)
        g = J.T @ r - e
        H = J.T @ J
        dH = np.diag(H).copy()
        improved = False
        for _ in range(12):
            step = np.linalg.solve(H + lam * np.diag(dH + 1.0), -g)
            step *= min(1.0, 1.0 / max(np.max(np.abs(step)), 1e-300))  # at most e-fold per step
            zn = np.clip(z + step, lo_z, hi_z)
            fn, rn = F(zn)
            if np.isfinite(fn) and fn < f:
                improved = True
                break
            lam *= 10
        if not improved:
            break
        conv = f - fn < tol * max(1.0, abs(f))
        z, f, r = zn, fn, rn
        lam = max(lam / 10, 1e-12)
        if conv or np.max(np.abs(step)) < 1e-9:
            break
    return z
